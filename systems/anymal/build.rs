//! Generate the kinematic filter's module from its spec, as any user's crate does
//! (cbfgen-build in checked-in mode: generated/ is committed, so a build without Python
//! uses it after checking its inputs hash). The whole-body controller's and the MPC's
//! modules, from the specs beside it, are generated in cbfgen-anymal-dynamics.

fn main() {
    cbfgen_build::Generator::new().spec("spec/anymal.py").checked_in("generated").build();
}
