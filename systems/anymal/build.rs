//! Generate this crate's three modules from their specs (the kinematic filter's, the
//! whole-body controller's and the kino-dynamic MPC's), as any user's crate does (cbfgen-build in
//! checked-in mode: generated/ is committed, so a build without Python uses it after
//! checking its inputs hash).

fn main() {
    cbfgen_build::Generator::new()
        .spec("spec/anymal.py")
        .spec("spec/anymal_wbc.py")
        .spec("spec/anymal_mpc.py")
        .checked_in("generated")
        .build();
}
