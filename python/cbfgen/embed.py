"""A system for C and C++ programs: its static and shared library, headers and CMake package.

``python -m cbfgen.embed install --prefix DIR SYSTEM...`` builds each SYSTEM — a built-in
system's name (``double_integrator``) or a spec file (``path/to/my_robot.py``) — as a
library exporting the system's entry table (``cbfgen_<name>_plugin_v1``, the core's
versioned C ABI), and installs into DIR::

    include/cbfgen/abi.h, cbfgen.h, cbfgen.hpp     the ABI, the C helpers, the C++ wrapper
    include/cbfgen/systems/<name>.h                the system's entry point
    lib/libcbfgen_<name>.a, lib/libcbfgen_<name>.so
    lib/cmake/cbfgen/                              find_package(cbfgen COMPONENTS <name>)

Installing more systems into the same DIR adds them. A C++ project then does::

    find_package(cbfgen REQUIRED COMPONENTS double_integrator)
    target_link_libraries(my_controller PRIVATE cbfgen::cpp cbfgen::double_integrator)

(``cbfgen::<name>_static`` links the static library instead, which carries the core and
Rust's standard library: static libraries of one install link together, those of two
different builds are not meant to; shared ones mix freely).
Building needs what :func:`cbfgen.load` needs; a built-in system also needs a clone of
cbfgen (its crate): ``CBFGEN_SOURCE``, or the clone around the working directory. A spec
builds from the sources embedded in this module when there is no clone, as
:func:`cbfgen.load` does. docs/embedding.md has more.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import re
import shutil
import sys
from pathlib import Path

from . import plugins
from .plugins import LoadError

VERSION = importlib.metadata.version("cbfgen")  # the wheel's, which maturin takes from Cargo.toml

# Built-in systems: name -> (crate folder, the path of its `SYSTEM` in the crate). One
# line each, as python/src/registry.rs lists them for the Python module.
BUILT_IN = {
    "anymal": ("systems/anymal", "cbfgen_anymal::generated::SYSTEM"),
    "anymal_mpc": ("systems/anymal", "cbfgen_anymal::mpc_generated::SYSTEM"),
    "anymal_wbc": ("systems/anymal", "cbfgen_anymal::wbc_generated::SYSTEM"),
    "double_integrator": ("systems/double_integrator", "cbfgen_double_integrator::SYSTEM"),
    "panda": ("systems/panda", "cbfgen_panda::generated::SYSTEM"),
    "panda_spheres": ("systems/panda_spheres", "cbfgen_panda_spheres::generated::SYSTEM"),
    "tachyon3": ("systems/tachyon3", "cbfgen_tachyon3::generated::SYSTEM"),
}

MANIFEST = """[package]
name = "cbfgen_c_{name}"
version = "0.0.0"
edition = "2021"
publish = false

[lib]
crate-type = ["staticlib", "cdylib"]
path = "lib.rs"

[dependencies]
cbfgen = {{ path = "{source}" }}
{dependency}
[build-dependencies]
cbfgen-build = {{ path = "{source}/cbfgen-build" }}

[workspace]
"""
# The shared library's SONAME is its installed name, so programs find it by that name.
BUILD_RS = """fn main() {{
    println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,libcbfgen_{name}.so");
{generate}}}
"""
GENERATE_RS = '    cbfgen_build::Generator::new().spec({spec}).checked_in("generated").build();\n'
LIB_RS_BUILT_IN = """//! The built-in system `{name}` for C and C++ (cbfgen.embed).

cbfgen::export_c!({path}, "{name}");
"""
LIB_RS_SPEC = """//! `{name}`, generated from {spec}, for C and C++ (cbfgen.embed).

#[allow(dead_code, clippy::all)]
mod system {{
    include!(concat!(env!("CARGO_MANIFEST_DIR"), "/generated/{name}.rs"));
}}

cbfgen::export_c!(system::SYSTEM, "{name}");
"""

SYSTEM_HEADER = """// The system `{name}` from C and C++: its entry table. Written by cbfgen.embed.
#ifndef CBFGEN_SYSTEM_{upper}_H
#define CBFGEN_SYSTEM_{upper}_H

#include <cbfgen/cbfgen.h>

#ifdef __cplusplus
extern "C" {{
#endif

// {doc}
// Check it once with cbfgen_check (cbfgen::System does); it lives as long as the program.
const cbfgen_plugin_v1 *cbfgen_{name}_plugin_v1(void);

#ifdef __cplusplus
}}
#endif

#endif  // CBFGEN_SYSTEM_{upper}_H
"""

SYSTEM_CMAKE = """# cbfgen system `{name}`, written by cbfgen.embed (included by cbfgenConfig.cmake).
if(NOT TARGET cbfgen::{name})
  add_library(cbfgen::{name} SHARED IMPORTED)
  set_target_properties(cbfgen::{name} PROPERTIES
    IMPORTED_LOCATION "${{_cbfgen_prefix}}/lib/libcbfgen_{name}.so"
    IMPORTED_SONAME "libcbfgen_{name}.so"
    INTERFACE_LINK_LIBRARIES cbfgen::c)
endif()
if(NOT TARGET cbfgen::{name}_static)
  add_library(cbfgen::{name}_static STATIC IMPORTED)
  set_target_properties(cbfgen::{name}_static PROPERTIES
    IMPORTED_LOCATION "${{_cbfgen_prefix}}/lib/libcbfgen_{name}.a"
    INTERFACE_LINK_LIBRARIES "cbfgen::c;{native}")
endif()
"""

NAME = re.compile(r"[a-z_][a-z0-9_]*")


def _crate(source: Path, system: str, folder: Path, progress: bool) -> tuple[str, str]:
    """Write the crate that exports ``system`` into ``folder``; its name and description."""
    spec = Path(system)
    if system in BUILT_IN:
        crate_folder, path = BUILT_IN[system]
        if not (source / crate_folder).is_dir():
            raise LoadError(f"cbfgen.embed: the built-in system {system} is built from its crate in a clone of "
                            f"cbfgen, and {source} is not one: run from a clone, or set {plugins.SOURCE_ENV} to one "
                            "(a spec file needs no clone)")
        crate_name = path.split("::")[0].replace("_", "-")
        dependency = f'{crate_name} = {{ path = "{(source / crate_folder).as_posix()}" }}\n'
        name, lib = system, LIB_RS_BUILT_IN.format(name=system, path=path)
        generate = ""
        doc = f"The built-in system {system} ({crate_folder} in cbfgen)."
    elif spec.suffix == ".py" and spec.is_file():
        spec = spec.resolve()
        generated = plugins._generate(source, spec)
        name = generated.name
        plugins._write_generated(folder, generated, "cbfgen.embed", progress)
        dependency, lib = "", LIB_RS_SPEC.format(name=name, spec=spec.name)
        generate = GENERATE_RS.format(spec=plugins._quoted(spec))
        doc = f"The system {name}, generated from {spec}."
    else:
        known = ", ".join(sorted(BUILT_IN))
        raise LoadError(f"cbfgen.embed: {system!r} is neither a built-in system ({known}) nor a spec file")
    if not NAME.fullmatch(name):
        raise LoadError(f"cbfgen.embed: the system name {name!r} is not a C identifier (lower case, digits, _)")
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "Cargo.toml").write_text(MANIFEST.format(name=name, source=source.as_posix(), dependency=dependency))
    (folder / "build.rs").write_text(BUILD_RS.format(name=name, generate=generate))
    (folder / "lib.rs").write_text(lib)
    return name, doc


def _native_libs(cargo_output: list[str]) -> str:
    """The system libraries a Rust static library needs, as rustc printed them, for CMake."""
    for line in cargo_output:
        if "native-static-libs:" in line:
            flags = line.split("native-static-libs:", 1)[1].split()
            return ";".join(f.removeprefix("-l") for f in flags if f.startswith("-l"))
    raise LoadError("cbfgen.embed: rustc did not print the static library's native libraries")


def install(systems: list[str], prefix: str | Path, *, progress: bool = True) -> list[str]:
    """Build each of ``systems`` (built-in names or spec files) and install it, with the
    headers and the CMake package, under ``prefix``. Returns the systems' names."""
    prefix = Path(prefix).resolve()
    source = plugins.source_dir(Path.cwd())
    capi = source / "capi"  # in a clone, or among the sources embedded in this module
    cargo = plugins._cargo()
    names = []
    for system in systems:
        folder = plugins.cache_dir() / "embed" / (Path(system).stem if system.endswith(".py") else system)
        name, doc = _crate(source, system, folder, progress)
        # `cargo rustc` builds both libraries and prints what the static one links against.
        args = ("rustc", "--release", "--lib", "--", "--print", "native-static-libs")
        target, output = plugins.cargo_build(cargo, source, folder, "cbfgen.embed", name, progress, args)
        (prefix / "lib" / "cmake" / "cbfgen").mkdir(parents=True, exist_ok=True)
        (prefix / "include" / "cbfgen" / "systems").mkdir(parents=True, exist_ok=True)
        for suffix in (".a", ".so"):
            installed = prefix / "lib" / f"libcbfgen_{name}{suffix}"
            shutil.copy2(target / "release" / f"libcbfgen_c_{name}{suffix}", installed.with_suffix(".tmp"))
            installed.with_suffix(".tmp").replace(installed)
        header = SYSTEM_HEADER.format(name=name, upper=name.upper(), doc=doc)
        (prefix / "include" / "cbfgen" / "systems" / f"{name}.h").write_text(header)
        cmake = SYSTEM_CMAKE.format(name=name, native=_native_libs(output))
        (prefix / "lib" / "cmake" / "cbfgen" / f"cbfgen_system_{name}.cmake").write_text(cmake)
        names.append(name)
    for header in ("abi.h", "cbfgen.h", "cbfgen.hpp"):
        shutil.copy2(capi / "include" / "cbfgen" / header, prefix / "include" / "cbfgen" / header)
    for file in ("cbfgenConfig.cmake", "cbfgenConfigVersion.cmake"):
        text = (capi / "cmake" / file).read_text().replace("@CBFGEN_VERSION@", VERSION)
        (prefix / "lib" / "cmake" / "cbfgen" / file).write_text(text)
    if progress:
        print(f"cbfgen.embed: installed {', '.join(names)} into {prefix}", file=sys.stderr)
    return names


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m cbfgen.embed", description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    installing = commands.add_parser("install", help="build systems and install them for C and C++")
    installing.add_argument("systems", nargs="+", metavar="SYSTEM",
                            help=f"a built-in system ({', '.join(sorted(BUILT_IN))}) or a spec file")
    installing.add_argument("--prefix", required=True, help="the folder to install into (like CMake's prefix)")
    installing.add_argument("--quiet", action="store_true", help="print nothing but errors")
    args = parser.parse_args(argv)
    try:
        install(args.systems, args.prefix, progress=not args.quiet)
    except LoadError as e:
        print(e, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
