//! The systems this module is built with: one line per system crate it links, the
//! registry the core's type-erased layer picks from by name. A new built-in system is a
//! line here and a dependency in Cargo.toml; its classes need no binding code.

use cbfgen::dynamic::Registry;
use cbfgen::system::KernelEntry;

/// Every built-in system, in name order.
pub static SYSTEMS: Registry = Registry::new(&[
    cbfgen_anymal::generated::SYSTEM,
    cbfgen_double_integrator::SYSTEM,
    cbfgen_panda::generated::SYSTEM,
    cbfgen_panda_spheres::generated::SYSTEM,
    cbfgen_tachyon3::generated::SYSTEM,
]);

/// Each built-in system's uniform kernel table, by module name; the core's primitives
/// (`cbfgen::generated::KERNELS`) come first in [`kernels`].
const SYSTEM_KERNELS: &[(&str, &[KernelEntry])] = &[
    ("anymal", cbfgen_anymal::generated::KERNELS),
    ("double_integrator", cbfgen_double_integrator::KERNELS),
    ("panda", cbfgen_panda::generated::KERNELS),
    ("panda_spheres", cbfgen_panda_spheres::generated::KERNELS),
    ("tachyon3", cbfgen_tachyon3::generated::KERNELS),
];

/// Every generated module's kernel table, by module name: the core's primitives, then
/// each system's.
pub fn kernels() -> impl Iterator<Item = &'static (&'static str, &'static [KernelEntry])> {
    cbfgen::generated::KERNELS.iter().chain(SYSTEM_KERNELS)
}
