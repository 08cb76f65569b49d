//! Write `include/cbfgen/abi.h` from the core's sources (`scripts/cbf generate` runs this).

use std::path::Path;
use std::process::ExitCode;

fn main() -> ExitCode {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    match cbfgen_capi::abi_header(&root.join("src")) {
        Ok(text) => match std::fs::write(root.join(cbfgen_capi::ABI_HEADER), text) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("cbfgen-abi-header: cannot write {}: {e}", cbfgen_capi::ABI_HEADER);
                ExitCode::FAILURE
            }
        },
        Err(e) => {
            eprintln!("cbfgen-abi-header: cbindgen refused the core's ABI: {e}");
            ExitCode::FAILURE
        }
    }
}
