"""A user's spec as a system, from Python: generated, built as a plugin, cached, loaded.

:func:`load` takes a spec file (the same file a Rust crate's ``build.rs`` would name),
builds it against cbfgen's core as a small shared library exporting the core's versioned
C ABI (``cbfgen::plugin``: the only thing that crosses is plain data and ``extern "C"``
calls, so the plugin and this module need not come from one compiler run), and loads it.
The build is cached by its inputs — the spec, every file it imports or names with
``depends_on``, and the core's and generator's sources — in a per-user directory. An
index keyed by the spec's bytes records what its last run depended on, so the same inputs
a second time load without running the spec: hashing the inputs and opening the library. The returned :class:`System`
is like any built-in one: ``Params``, ``Rows``, ``EcbfFilter`` and the dynamics take it,
and ``System(name)`` finds it afterwards.

Building needs what building a Rust crate on cbfgen needs: Rust (``cargo``), Python with
SymEngine (this interpreter), CMake for OSQP's C sources, and cbfgen's sources: a clone
named by ``CBFGEN_SOURCE`` or found around the spec or the working directory, else the
sources embedded in this module (written once into the cache as a crate of their own), so
an installed wheel needs no clone at all.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import shutil
import subprocess
import sys
import time
import tomllib
from pathlib import Path

from . import _native

ABI_VERSION = _native.PLUGIN_ABI_VERSION  # a cached build of another ABI is never reused
SOURCE_ENV = "CBFGEN_SOURCE"
CACHE_ENV = "CBFGEN_CACHE"


class LoadError(RuntimeError):
    """A spec could not be built as a plugin: the message's one line names the fix."""


def cache_dir() -> Path:
    """Where builds are kept: ``CBFGEN_CACHE``, else ``$XDG_CACHE_HOME/cbfgen``, else
    ``~/.cache/cbfgen``."""
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "cbfgen"


def _is_source(folder: Path) -> bool:
    manifest = folder / "Cargo.toml"
    return (manifest.is_file() and (folder / "cbfgen-build").is_dir() and (folder / "symbolic").is_dir()
            and 'name = "cbfgen"' in manifest.read_text())


def source_dir(near: Path | None = None) -> Path:
    """cbfgen's sources: ``CBFGEN_SOURCE``, else the first folder at or above ``near`` or
    the working directory that is a clone of cbfgen, else the sources this module was built
    from, embedded in it (see :func:`embedded_source`)."""
    named = os.environ.get(SOURCE_ENV)
    if named:
        if not _is_source(Path(named)):
            raise LoadError(f"{SOURCE_ENV}={named} is not a clone of cbfgen (no Cargo.toml of the cbfgen crate "
                            "beside cbfgen-build/ and symbolic/)")
        return Path(named).resolve()
    for start in [p for p in (near, Path.cwd()) if p is not None]:
        for folder in [start.resolve(), *start.resolve().parents]:
            if _is_source(folder):
                return folder
    return embedded_source()


def embedded_source() -> Path:
    """The core's sources embedded in this module, written once per content into the
    cache (``source/<hash>``) as a crate of its own: exactly the core this module was
    built from, with no clone needed."""
    files = _native.core_sources()
    digest = hashlib.sha256()
    for path, data in files:
        digest.update(path.encode() + b"\0" + data + b"\0")
    folder = cache_dir() / "source" / digest.hexdigest()[:20]
    if _is_source(folder):
        return folder
    staging = folder.with_name(f"{folder.name}.{os.getpid()}.tmp")
    shutil.rmtree(staging, ignore_errors=True)
    for path, data in files:
        target = staging / path
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(standalone_manifest(data.decode()).encode() if path == "Cargo.toml" else data)
    try:
        os.replace(staging, folder)
    except OSError:  # another process wrote the same sources first
        shutil.rmtree(staging, ignore_errors=True)
    return folder


def standalone_manifest(workspace_manifest: str) -> str:
    """The core's manifest (the repository's root, also the workspace's) as a crate of its
    own: what it inherits from the workspace resolved, its tests, benches and
    dev-dependencies (not embedded) left out."""
    root = tomllib.loads(workspace_manifest)
    shared, package = root["workspace"], root["package"]
    lines = ["[package]"]
    for key in ("name", "version", "edition", "rust-version", "license", "build"):
        if key in package:
            value = package[key]
            if isinstance(value, dict) and value.get("workspace"):
                value = shared["package"][key]
            lines.append(f"{key} = {_toml(value)}")
    lines += ["autobins = false", "autoexamples = false", "autotests = false", "autobenches = false"]
    for section in ("features", "dependencies", "build-dependencies"):
        lines += ["", f"[{section}]"]
        for name, value in root.get(section, {}).items():
            if section != "features":
                value = _inherited_dependency(value, shared.get("dependencies", {}).get(name))
            lines.append(f"{_toml_key(name)} = {_toml(value)}")
    lines += ["", "# Its own workspace: never a member of whatever folder the cache sits in.", "[workspace]", ""]
    return "\n".join(lines)


def _inherited_dependency(local, shared):
    """A dependency as cargo resolves ``name.workspace = true``: the workspace's entry, the
    member's keys on top and its features added."""
    if not (isinstance(local, dict) and local.get("workspace")):
        return local
    resolved = {"version": shared} if isinstance(shared, str) else dict(shared)
    for key, value in local.items():
        if key == "features":
            resolved["features"] = [*resolved.get("features", []), *value]
        elif key != "workspace":
            resolved[key] = value
    return resolved


def _toml_key(key: str) -> str:
    return key if key.replace("-", "").replace("_", "").isalnum() else json.dumps(key)


def _toml(value) -> str:
    """A TOML value (strings, booleans, numbers, arrays, inline tables: what a manifest holds)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a TOML basic string
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"no TOML form for {value!r}")


def _source_files(source: Path) -> list[Path]:
    """The core's, the build helper's and the generator's sources: what a plugin is built from."""
    found = [source / name for name in ("Cargo.toml", "Cargo.lock", "build.rs", "rustfmt.toml")]
    for folder, suffixes in (("src", (".rs",)), ("generated", (".rs",)), ("cbfgen-build", (".rs", ".toml")),
                             ("symbolic", (".py", ".toml", ".txt"))):
        found += [p for p in (source / folder).rglob("*") if p.is_file() and p.suffix in suffixes
                  and "tests" not in p.relative_to(source).parts and "__pycache__" not in p.parts]
    return sorted(found)


def _key(source: Path, spec: Path, dependencies: list[Path]) -> str:
    h = hashlib.sha256(f"cbfgen plugin ABI {ABI_VERSION}\0".encode())
    digests = _Digests.of(cache_dir())
    for path in [*_source_files(source), spec, *dependencies]:
        h.update(str(path).encode() + b"\0" + digests.digest(path) + b"\0")
    digests.save()
    return h.hexdigest()[:20]


class _Digests:
    """Each input file's SHA-256, kept in the cache (``digests.json``) by its size,
    modification time and inode, so that a warm load reads no file whose stamp is
    unchanged: a spec that names large data (a robot's meshes) with ``depends_on`` loads
    in milliseconds, not in the time it takes to hash them. A changed file has a new
    stamp and is read again (files modified in the last 2 s are not remembered, so a
    second change within one tick of the clock is never missed)."""

    _open: dict[Path, _Digests] = {}

    def __init__(self, file: Path):
        self.file = file
        try:
            self.known: dict[str, list[str]] = json.loads(file.read_text())
        except (OSError, ValueError):  # none yet, or torn
            self.known = {}
        self.changed = False

    @classmethod
    def of(cls, cache: Path) -> _Digests:
        if cache not in cls._open:
            cls._open[cache] = cls(cache / "digests.json")
        return cls._open[cache]

    def digest(self, path: Path) -> bytes:
        stat = path.stat()
        stamp = f"{stat.st_size}:{stat.st_mtime_ns}:{stat.st_ino}"
        known = self.known.get(str(path))
        if known is not None and known[0] == stamp:
            return bytes.fromhex(known[1])
        digest = hashlib.sha256(path.read_bytes()).digest()
        # Only a file settled for a while is remembered: one written within the clock's
        # tick of being hashed could change again with the same stamp.
        if stat.st_mtime_ns < time.time_ns() - 2_000_000_000:
            self.known[str(path)] = [stamp, digest.hex()]
            self.changed = True
        return digest

    def save(self) -> None:
        if not self.changed:
            return
        self.file.parent.mkdir(parents=True, exist_ok=True)
        staging = self.file.with_name(f"{self.file.name}.{os.getpid()}.tmp")
        staging.write_text(json.dumps(self.known))
        os.replace(staging, self.file)  # readers see the old table or the new one
        self.changed = False


def _index_entry(source: Path, spec: Path) -> Path:
    """Where a spec's last build is indexed: by the spec's own bytes and where it and the
    sources are, so a warm load finds its plugin without running the spec."""
    h = hashlib.sha256(f"cbfgen plugin index {ABI_VERSION}\0{source}\0{spec}\0".encode())
    h.update(spec.read_bytes())
    return cache_dir() / "plugins" / "index" / f"{h.hexdigest()[:20]}.json"


def _indexed(entry: Path, source: Path, spec: Path) -> Path | None:
    """The library the index names, when every input it was built from (the spec, the
    dependencies its run recorded, the sources) is unchanged; else None. A dependency the
    spec would newly import can only come from a change to the spec or to a recorded
    dependency, and either changes the key."""
    try:
        recorded = json.loads(entry.read_text())
        dependencies = [Path(d) for d in recorded["dependencies"]]
        library = cache_dir() / "plugins" / recorded["folder"] / recorded["library"]
        key = _key(source, spec, dependencies)
    except (OSError, ValueError, KeyError, TypeError):  # no entry, a torn one, a dependency gone
        return None
    return library if key == recorded["key"] and library.is_file() else None


def _write_index(entry: Path, key: str, dependencies: list[Path], library: Path) -> None:
    record = {"key": key, "dependencies": [str(d) for d in dependencies], "folder": library.parent.name,
              "library": library.name}
    entry.parent.mkdir(parents=True, exist_ok=True)
    staging = entry.with_name(f"{entry.name}.{os.getpid()}.tmp")
    staging.write_text(json.dumps(record))
    os.replace(staging, entry)  # readers see the old entry or the new one, never half


@dataclasses.dataclass(frozen=True)
class Generated:
    """A spec's module, generated in this process."""

    name: str
    """The system's name."""
    text: str
    """The module (``<name>.rs``), headed by its inputs hash."""
    dependencies: list[Path]
    """The files the spec imports from its folder or names with ``depends_on``."""
    warnings: list[str]
    """The generator's warnings about the spec's families."""


def _generate(source: Path, spec: Path) -> Generated:
    """The spec's module, generated by the generator of ``source`` in this process (what
    the plugin's build script would run), so that a spec mistake is a :class:`LoadError`
    naming its file and line before anything compiles."""
    try:
        import symengine  # noqa: F401
    except ImportError:
        raise LoadError(f"cbfgen.load generates the spec with SymEngine: {sys.executable} -m pip install "
                        "symengine==0.15.0") from None
    sys.path.insert(0, str(source))
    try:
        from symbolic.__main__ import failure
        from symbolic.codegen.generate import render_with_warnings

        try:
            file, text, dependencies, warnings = render_with_warnings(spec, "cbfgen")
        except SystemExit as stop:  # the generator's own stop (rustfmt missing or refusing)
            raise LoadError(f"cbfgen.load {spec}: {stop}") from None
        except Exception as exc:  # the spec's mistakes, and its own bugs, with where they are
            raise LoadError(f"cbfgen.load: {failure(exc, spec)}") from exc
    finally:
        sys.path.remove(str(source))
    return Generated(Path(file).stem, text, list(dependencies), list(warnings))


MANIFEST = """[package]
name = "cbfgen_plugin_{name}"
version = "0.0.0"
edition = "2021"
publish = false

[lib]
crate-type = ["cdylib"]
path = "lib.rs"

[dependencies]
cbfgen = {{ path = "{source}" }}

[build-dependencies]
cbfgen-build = {{ path = "{source}/cbfgen-build" }}

[workspace]
"""
# The module is generated before the build (`_generate`) into `generated/`: the build
# script checks its inputs hash and uses it as it is.
BUILD_RS = """fn main() {{
    cbfgen_build::Generator::new().spec({spec}).checked_in("generated").build();
}}
"""
LIB_RS = """//! cbfgen.load's plugin of `{name}`, generated from {spec}.

#[allow(dead_code, clippy::all)]
mod system {{
    include!(concat!(env!("CARGO_MANIFEST_DIR"), "/generated/{name}.rs"));
}}

cbfgen::export_plugin!(system::SYSTEM);
"""


def _cargo() -> str:
    """cargo's path, or the LoadError naming the fix."""
    cargo = shutil.which("cargo")
    if cargo is None:
        raise LoadError("cbfgen.load builds the spec with Rust, and cargo is not on PATH: install Rust "
                        "(https://rustup.rs)")
    return cargo


def _write_generated(crate: Path, generated: Generated, label: str, progress: bool) -> None:
    """The spec's module into ``crate/generated/``, its warnings to stderr."""
    (crate / "generated").mkdir(parents=True, exist_ok=True)
    (crate / "generated" / f"{generated.name}.rs").write_text(generated.text)
    for warning in generated.warnings if progress else []:
        print(f"{label} {generated.name}: warning: {warning}", file=sys.stderr)


def _quoted(path: Path) -> str:
    """``path`` as a Rust string literal."""
    return '"' + str(path).replace("\\", "\\\\").replace('"', '\\"') + '"'


def cargo_build(cargo: str, source: Path, crate: Path, label: str, what: str, progress: bool,
                args: tuple[str, ...] = ("build", "--release")) -> tuple[Path, list[str]]:
    """Build the crate in ``crate`` against the core in ``source`` (``cargo <args>``), in
    the target folder every such build shares; returns that folder and cargo's output.
    ``progress`` prints its stages as ``<label> <what>: ...``; a failed build is a
    :class:`LoadError` with the compiler's first error."""
    if not (crate / "Cargo.lock").is_file():  # the core's versions, not whatever is newest
        shutil.copy2(source / "Cargo.lock", crate / "Cargo.lock")
    # Shared: the core compiles once for every spec (CARGO_TARGET_DIR, if set, is used as is).
    target = Path(os.environ.get("CARGO_TARGET_DIR") or cache_dir() / "target")
    env = {**os.environ, "CARGO_TARGET_DIR": str(target), "CBFGEN_PYTHON": sys.executable}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"  # the venv's cmake
    start = time.monotonic()
    done = subprocess.Popen([cargo, *args[:1], "--manifest-path", str(crate / "Cargo.toml"), *args[1:]],
                            cwd=crate, env=env, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    lines = []
    live = progress and sys.stderr.isatty()  # one line redrawn; a log gets the start and the end
    if progress and not live:
        print(f"{label} {what}: building (the first build compiles the core too)", file=sys.stderr)
    assert done.stderr is not None
    for line in done.stderr:
        lines.append(line)
        text = line.strip()
        if live and text.startswith(("Compiling", "Finished")):
            print(f"\r{label} {what}: {text[:60]:<60} {time.monotonic() - start:5.0f} s", end="",
                  file=sys.stderr, flush=True)
    if live:
        print(file=sys.stderr)
    elif progress:
        print(f"{label} {what}: built in {time.monotonic() - start:.0f} s", file=sys.stderr)
    if done.wait() != 0:
        errors = [line.rstrip() for line in lines if line.startswith("error")]
        detail = "".join(lines[-40:])
        raise LoadError(f"{label} {what}: the build failed: {errors[0] if errors else 'see below'}\n{detail}")
    return target, lines


def _build(cargo: str, source: Path, spec: Path, generated: Generated, crate: Path, library: Path,
           progress: bool) -> None:
    name = generated.name
    _write_generated(crate, generated, "cbfgen.load", progress)
    (crate / "Cargo.toml").write_text(MANIFEST.format(name=name, source=source.as_posix()))
    (crate / "build.rs").write_text(BUILD_RS.format(spec=_quoted(spec)))
    (crate / "lib.rs").write_text(LIB_RS.format(name=name, spec=spec.name))
    target, _ = cargo_build(cargo, source, crate, "cbfgen.load", str(spec), progress)
    built = target / "release" / f"libcbfgen_plugin_{name}.so"
    shutil.copy2(built, library.with_suffix(".tmp"))
    os.replace(library.with_suffix(".tmp"), library)  # a loaded library is never overwritten in place


def load(spec: str | os.PathLike, *, progress: bool = True) -> _native.System:
    """The system of the spec file ``spec``, built as a plugin (or taken from the cache
    when its inputs have not changed) and loaded. ``progress`` prints the build's stages.

    Raises :class:`LoadError` with one line naming the fix when a tool is missing, or the
    generator's or compiler's message when the spec does not build (a spec mistake names
    its file and line)."""
    spec = Path(spec).resolve()
    if not spec.is_file():
        raise LoadError(f"cbfgen.load: no spec file {spec}")
    source = source_dir(spec.parent)
    entry = _index_entry(source, spec)
    library = _indexed(entry, source, spec)
    if library is None:  # the spec runs only when an input changed or it was never built
        cargo = _cargo()
        # Generated here, before any compile: a spec mistake is reported in seconds.
        generated = _generate(source, spec)
        key = _key(source, spec, generated.dependencies)
        folder = cache_dir() / "plugins" / f"{generated.name}-{key}"
        library = folder / f"libcbfgen_plugin_{generated.name}.so"
        if not library.is_file():
            _build(cargo, source, spec, generated, folder, library, progress)
        _write_index(entry, key, generated.dependencies, library)
    return _native.load_plugin(library)
