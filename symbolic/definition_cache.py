"""The built-in systems' definitions, kept on disk between processes by their inputs.

Defining every built-in system (composed and unrolled) and every kernel of the core takes
about 40 s of CPU, and each process that reads them (every pytest worker, the SymEngine
cross-check, the composition test) used to define them again. :func:`cached` keeps what
one process built in ``target/symbolic-cache/`` and hands it to the next, keyed by
everything that can change it:

* the symbolic package (:func:`symbolic.inputs_hash.inputs_hash`),
* every file in each built-in spec's folder (the spec, the modules it imports from there,
  its data files) and every dependency its generated file's header names,
* the Python and SymEngine versions.

A changed input is a new key (the old entry is deleted when the new one is written); an
entry that cannot be read is defined again. ``CBFGEN_SYMBOLIC_CACHE=off`` turns the cache
off, ``CBFGEN_SYMBOLIC_CACHE=DIR`` moves it.

``python -m symbolic.definition_cache`` fills it (``scripts/cbf test`` runs that beside the
``--check`` of the generated files, on the other core).
"""

from __future__ import annotations

import hashlib
import os
import pickle
import platform
import re
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import symengine as se

from .codegen.output import REPO_ROOT
from .inputs_hash import inputs_hash

T = TypeVar("T")
_DEPENDS = re.compile(r"^// depends: (.*)$", re.MULTILINE)


def cache_dir(repo_root: Path = REPO_ROOT) -> Path | None:
    """Where entries live; None when ``CBFGEN_SYMBOLIC_CACHE=off``."""
    setting = os.environ.get("CBFGEN_SYMBOLIC_CACHE", "")
    if setting == "off":
        return None
    return Path(setting) if setting else repo_root / "target" / "symbolic-cache"


def inputs_key(specs: list[Path], repo_root: Path = REPO_ROOT,
               generated_dir: Callable[[Path], Path] = lambda spec: spec.parent.parent / "generated") -> str:
    """SHA-256 over the symbolic package's hash, the Python and SymEngine versions and,
    per spec, every file of its folder tree and every dependency its generated file (in
    ``generated_dir(spec)``: its crate's generated/) names (paths relative to
    ``repo_root``, in byte order, each path NUL bytes NUL)."""
    files: set[Path] = set()
    for spec in specs:
        files.update(p for p in spec.parent.rglob("*") if p.is_file() and "__pycache__" not in p.parts)
        generated = generated_dir(spec) / f"{spec.stem}.rs"
        if generated.is_file():
            for line in _DEPENDS.findall(generated.read_text()[:4096]):
                files.update((spec.parent / name.strip()).resolve() for name in line.split(","))
    h = hashlib.sha256()
    for part in ("cbfgen-definitions", inputs_hash(repo_root), platform.python_version(), se.__version__):
        h.update(part.encode() + b"\0")
    for path in sorted(files, key=lambda p: p.as_posix().encode()):
        h.update(os.path.relpath(path, repo_root).encode() + b"\0")
        h.update((path.read_bytes() if path.is_file() else b"<missing>") + b"\0")
    return h.hexdigest()


def cached(kind: str, key: str, define: Callable[[], T], repo_root: Path = REPO_ROOT) -> T:
    """``define()``, or what it returned in a process before with the same ``kind`` and
    ``key``; a fresh result is stored (atomically: a reader never sees half a file)."""
    folder = cache_dir(repo_root)
    if folder is None:
        return define()
    entry = folder / f"{kind}-{key}.pickle"
    try:
        with entry.open("rb") as f:
            return pickle.load(f)
    except FileNotFoundError:
        pass
    except Exception:  # a damaged or foreign entry: define again and replace it
        entry.unlink(missing_ok=True)
    value = define()
    folder.mkdir(parents=True, exist_ok=True)
    with tempfile.NamedTemporaryFile(dir=folder, prefix=f".{kind}-", delete=False) as f:
        pickle.dump(value, f, protocol=pickle.HIGHEST_PROTOCOL)
    os.replace(f.name, entry)
    for old in folder.glob(f"{kind}-*.pickle"):
        if old != entry:
            old.unlink(missing_ok=True)
    return value


if __name__ == "__main__":
    from .generate import all_kernels, builtin_systems

    builtin_systems()
    builtin_systems(unrolled=True)
    all_kernels()
