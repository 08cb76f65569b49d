//! The committed C header is what cbindgen writes from the core's ABI today: a change to
//! the table or its types that was not regenerated fails here, naming the command.

use std::path::Path;

#[test]
fn abi_header_is_current() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let fresh = cbfgen_capi::abi_header(&root.join("src")).expect("cbindgen parses the core's ABI");
    let committed = std::fs::read_to_string(root.join(cbfgen_capi::ABI_HEADER)).unwrap_or_default();
    assert!(
        fresh == committed,
        "{} is not what the core's src/plugin/ declares: run `scripts/cbf generate` (or \
         `cargo run -p cbfgen-capi --bin cbfgen-abi-header`) and commit it",
        cbfgen_capi::ABI_HEADER
    );
    // The numbers C reads must be the core's own.
    assert!(fresh.contains(&format!("#define CBFGEN_ABI_VERSION {}", cbfgen::plugin::ABI_VERSION)));
    assert!(fresh.contains(&format!("#define CBFGEN_ERROR_CAPACITY {}", cbfgen::plugin::ERROR_CAPACITY)));
}
