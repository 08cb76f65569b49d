//! Generate this system's module from its spec, as any user's crate does (cbfgen-build in
//! checked-in mode: generated/ is committed, so a build without Python uses it after
//! checking its inputs hash).

fn main() {
    cbfgen_build::Generator::new().spec("spec/anymal.py").checked_in("generated").build();
}
