//! # cbfgen-capi — cbfgen from C and C++
//!
//! A generated system reaches C through the core's versioned plugin ABI
//! ([`cbfgen::plugin`](../cbfgen/plugin/index.html)): one `extern "C"` table of entry points
//! per system, plain `#[repr(C)]` data, caller-owned buffers, nothing that unwinds. This
//! crate keeps its C face:
//!
//! * `include/cbfgen/abi.h`, the table and its types as C declares them, generated from
//!   the core's Rust source by cbindgen ([`abi_header`]; `scripts/cbf generate` writes it,
//!   a test checks it is current), so the two can never disagree;
//! * `include/cbfgen/cbfgen.h`, C99 helpers over the table (checking the ABI, finding a
//!   family by name, sizing the report), and `include/cbfgen/cbfgen.hpp`, the header-only
//!   C++17 wrapper (RAII, Eigen maps);
//! * `cmake/`, the CMake package a C++ project finds with `find_package(cbfgen)`.
//!
//! `python -m cbfgen.embed install` builds a system's static and shared library and
//! installs them with these headers (docs/embedding.md).

use std::collections::HashMap;
use std::path::Path;

/// The core's files that declare what crosses the ABI.
const ABI_SOURCES: [&str; 5] = ["plugin/mod.rs", "dynamic.rs", "filter/work.rs", "filter/verdict.rs", "limits.rs"];

/// Rust names and their C names (`cbfgen_` + snake case for types; constants in capitals
/// under the name of what they select).
const TYPES: [(&str, &str); 24] = [
    ("PluginV1", "cbfgen_plugin_v1"),
    ("ErrorC", "cbfgen_error"),
    ("ErrorCode", "cbfgen_error_code"),
    ("StrC", "cbfgen_str"),
    ("DomainC", "cbfgen_domain"),
    ("ParamC", "cbfgen_param"),
    ("FamilyParamsC", "cbfgen_family_params"),
    ("FamilyC", "cbfgen_family"),
    ("SlotC", "cbfgen_slot"),
    ("KernelC", "cbfgen_kernel"),
    ("DescriptionC", "cbfgen_description"),
    ("SolverC", "cbfgen_solver"),
    ("SettingsC", "cbfgen_settings"),
    ("RowLayoutC", "cbfgen_row_layout"),
    ("RowC", "cbfgen_row"),
    ("CauseC", "cbfgen_cause"),
    ("SafetyC", "cbfgen_safety"),
    ("ReportC", "cbfgen_report"),
    ("WorstCaseC", "cbfgen_worst_case"),
    ("CapacityCount", "cbfgen_capacity_count"),
    ("FamilyRelaxation", "cbfgen_family_relaxation"),
    ("Work", "cbfgen_work"),
    ("Calibration", "cbfgen_calibration"),
    ("Handle", "cbfgen_handle"),
];
const STORE_OPS: [&str; 10] =
    ["EXISTS", "LEN", "SLOTS", "IS_ENABLED", "GET", "SET", "PUSH", "REMOVE", "CLEAR", "SET_ENABLED"];
const DYNAMICS_OPS: [&str; 3] = ["DRIFT", "INPUT_MATRIX", "XDOT"];
/// Items of the parsed files that are not part of the ABI.
const NOT_ABI: [&str; 7] =
    ["MAX_INSTANCES", "STATE_LIMIT", "PARAM_LIMIT", "TIME_LIMIT", "Safety", "Verdict", "ENTRY_POINT"];

/// Where this header is kept, relative to the repository's root.
pub const ABI_HEADER: &str = "capi/include/cbfgen/abi.h";

/// `include/cbfgen/abi.h` as cbindgen writes it from the core's sources under `core_src`
/// (the core crate's `src/`).
pub fn abi_header(core_src: &Path) -> Result<String, cbindgen::Error> {
    let mut config = cbindgen::Config {
        language: cbindgen::Language::C,
        cpp_compat: true,
        usize_is_size_t: true,
        style: cbindgen::Style::Both,
        include_guard: Some("CBFGEN_ABI_H".into()),
        no_includes: true,
        sys_includes: vec!["stdbool.h".into(), "stddef.h".into(), "stdint.h".into()],
        documentation_style: cbindgen::DocumentationStyle::C99,
        header: Some(
            "// cbfgen's C ABI: one table of entry points per system (cbfgen_<name>_plugin_v1()).\n\
             // Generated from the core's src/plugin/ by cbindgen (capi/src/lib.rs); do not edit:\n\
             // `scripts/cbf generate` writes it. Include <cbfgen/cbfgen.h>, which includes this."
                .into(),
        ),
        ..Default::default()
    };
    config.enumeration.rename_variants = cbindgen::RenameRule::ScreamingSnakeCase;
    config.enumeration.prefix_with_name = true;
    config.export.include = vec!["PluginV1".into(), "ErrorCode".into()];
    config.export.exclude = NOT_ABI.iter().map(|s| s.to_string()).collect();
    let mut rename: HashMap<String, String> = TYPES.iter().map(|(r, c)| (r.to_string(), c.to_string())).collect();
    for name in ["ABI_VERSION", "ERROR_CAPACITY", "MAX_RELATIVE_DEGREE"] {
        rename.insert(name.into(), format!("CBFGEN_{name}"));
    }
    for op in STORE_OPS {
        rename.insert(op.into(), format!("CBFGEN_STORE_{op}"));
    }
    for op in DYNAMICS_OPS {
        rename.insert(op.into(), format!("CBFGEN_DYNAMICS_{op}"));
    }
    config.export.rename = rename;
    let mut builder = cbindgen::Builder::new().with_config(config);
    for file in ABI_SOURCES {
        builder = builder.with_src(core_src.join(file));
    }
    let mut text = Vec::new();
    builder.generate()?.write(&mut text);
    Ok(String::from_utf8(text).expect("cbindgen writes UTF-8"))
}
