//! Test helpers shared by the cbfgen crates' tests and benches: random and hand-built box
//! pairs ([`boxes`]), Clarabel on a dense QP ([`clarabel_qp`]), a second solver's answer
//! to the lexicographic QP ([`lexicographic_reference`]), Table I's LP box–box query
//! ([`lp_boxes`]), the SSAT's 2-D collision boundary of Fig. 6 ([`ssat_boundary`]) and
//! per-outcome tallies ([`tally`]), whether a bench was started to measure or to be
//! checked ([`bench_run`]), and the Panda's kinematic tree node by node ([`panda_tree!`]).
//!
//! The allocation counter is not a module of this library: it installs a global allocator
//! and `malloc` hooks, which must be in the allocation-counting test binaries only. Those
//! include `testkit/alloc_count.rs` by path.

pub mod bench_run;
pub mod boxes;
pub mod clarabel_qp;
pub mod lexicographic_reference;
pub mod lp_boxes;
pub mod ssat_boundary;
pub mod tally;

/// The Panda's kinematic tree walked node by node at the state `$x`, in the generated
/// module `$gen` (the arm's or the spheres' — both are built from one kinematics): each
/// link frame's jet from its parent's, then each frame's value from its parent's, as a
/// cycle's pose cache computes them. `([jet of link 1 .. 7], [value of link 1 .. 7])`, the
/// jets as a tuple (each has its own column count). What the operation-count tests
/// replay on counting numbers.
#[macro_export]
macro_rules! panda_tree {
    ($gen:ident, $x:expr) => {{
        use cbfgen::compose::flatten;
        let x = $x;
        let j1 = $gen::frame_panda_link1(x);
        let j2 = $gen::frame_panda_link2(x, &j1.0, &j1.1, &flatten(&j1.2));
        let j3 = $gen::frame_panda_link3(x, &j2.0, &j2.1, &flatten(&j2.2));
        let j4 = $gen::frame_panda_link4(x, &j3.0, &j3.1, &flatten(&j3.2));
        let j5 = $gen::frame_panda_link5(x, &j4.0, &j4.1, &flatten(&j4.2));
        let j6 = $gen::frame_panda_link6(x, &j5.0, &j5.1, &flatten(&j5.2));
        let j7 = $gen::frame_panda_link7(x, &j6.0, &j6.1, &flatten(&j6.2));
        let v1 = $gen::frame_panda_link1_value(x);
        let v2 = $gen::frame_panda_link2_value(x, &v1);
        let v3 = $gen::frame_panda_link3_value(x, &v2);
        let v4 = $gen::frame_panda_link4_value(x, &v3);
        let v5 = $gen::frame_panda_link5_value(x, &v4);
        let v6 = $gen::frame_panda_link6_value(x, &v5);
        let v7 = $gen::frame_panda_link7_value(x, &v6);
        ((j1, j2, j3, j4, j5, j6, j7), [v1, v2, v3, v4, v5, v6, v7])
    }};
}
