//! Generate ANYmal's two dynamics modules from their specs, which sit beside the kinematic
//! filter's in `systems/anymal/spec/` and share its robot facts (`anymal_robot.py`): the
//! whole-body controller's and the kino-dynamic MPC's. Checked-in mode, as cbfgen-anymal.

fn main() {
    cbfgen_build::Generator::new()
        .spec("../anymal/spec/anymal_wbc.py")
        .spec("../anymal/spec/anymal_mpc.py")
        .checked_in("generated")
        .build();
}
