//! The systems this module is built with: one line per system crate it links, the
//! registry the core's type-erased layer picks from by name. A new built-in system is a
//! line here and a dependency in Cargo.toml; its classes need no binding code.

use cbfgen::dynamic::Registry;

/// Every built-in system, in name order.
pub static SYSTEMS: Registry = Registry::new(&[
    cbfgen_anymal::generated::SYSTEM,
    cbfgen_anymal::mpc_generated::SYSTEM,
    cbfgen_anymal::wbc_generated::SYSTEM,
    cbfgen_double_integrator::SYSTEM,
    cbfgen_panda::generated::SYSTEM,
    cbfgen_panda_spheres::generated::SYSTEM,
    cbfgen_tachyon3::generated::SYSTEM,
]);
