//! Every kernel the generator printed as one straight line performs exactly the operations
//! its `kernel_table!` line states: each is run on `Counted` numbers, which count what the
//! compiled code does (the core's own modules here; each system crate checks its own).

use cbfgen::generated;
use cbfgen::ops::{check_stated, Counted};

#[test]
fn the_core_kernels_perform_the_operations_they_state() {
    let ssat = check_stated(generated::ssat::run_counted_kernels::<Counted>).unwrap_or_else(|m| panic!("{m:#?}"));
    let sphere_box =
        check_stated(generated::sphere_box::run_counted_kernels::<Counted>).unwrap_or_else(|m| panic!("{m:#?}"));
    // Every kernel of both modules states its count.
    assert_eq!((ssat, sphere_box), (generated::ssat::KERNELS.len(), generated::sphere_box::KERNELS.len()));
    assert!(generated::KERNELS.iter().all(|(_, k)| k.iter().all(|e| e.ops.is_some_and(|o| o.total() > 0))));
}
