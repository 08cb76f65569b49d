"""The hash of everything generation reads; build.rs recomputes it the same way.

A system generated from a spec file (``python -m symbolic generate SPEC``) records
:func:`spec_inputs_hash` instead: the package hash below, the spec file's bytes, the
runtime crate path and the spec's dependency files (see :func:`spec_inputs_hash`), so a
build helper can tell a stale file from a current one. cbfgen-build recomputes that one
in Rust (cbfgen-build/src/inputs_hash.rs - keep it in step too).

Rule (mirrored in build.rs - keep the two in step): every file under ``symbolic/``
whose name ends in .py, .toml or .txt, skipping directories named ``tests``,
``__pycache__`` or starting with a dot. Files are taken in byte order of their
'/'-separated path relative to the repository root; the hash is SHA-256 over, for each
file, ``path`` + NUL + contents + NUL.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Iterable, Mapping
from pathlib import Path

HASHED_SUFFIXES = (".py", ".toml", ".txt")
SKIPPED_DIRS = ("tests", "__pycache__")


def input_files(repo_root: Path) -> list[Path]:
    found = []
    for path in (repo_root / "symbolic").rglob("*"):
        rel = path.relative_to(repo_root)
        dirs = rel.parts[:-1]
        if any(d in SKIPPED_DIRS or d.startswith(".") for d in dirs):
            continue
        if path.is_file() and path.name.endswith(HASHED_SUFFIXES):
            found.append(path)
    return sorted(found, key=lambda p: p.relative_to(repo_root).as_posix().encode())


def inputs_hash(repo_root: Path) -> str:
    h = hashlib.sha256()
    for path in input_files(repo_root):
        h.update(path.relative_to(repo_root).as_posix().encode())
        h.update(b"\0")
        h.update(path.read_bytes())
        h.update(b"\0")
    return h.hexdigest()


def dependency_entries(spec: Path, files: Iterable[Path]) -> dict[str, bytes]:
    """Relative path -> bytes of each of the spec's dependency files, the form
    :func:`spec_inputs_hash` takes. The path is relative to the spec's folder,
    '/'-separated, with ``..`` where a file lies outside that folder; both sides are
    resolved first, so it is the same wherever the folder lives."""
    base = Path(spec).resolve().parent
    return {Path(os.path.relpath(Path(f).resolve(), base)).as_posix(): Path(f).read_bytes() for f in files}


def spec_inputs_hash(repo_root: Path, spec: bytes, runtime_crate: str,
                     dependencies: Mapping[str, bytes] | None = None) -> str:
    """SHA-256 over ``"cbfgen-spec"`` NUL, :func:`inputs_hash` (hex) NUL, the spec
    file's bytes NUL, ``runtime_crate`` NUL, then for each dependency file, in byte order
    of its UTF-8 path: the path relative to the spec's folder ('/'-separated, see
    :func:`dependency_entries`) NUL, its bytes NUL. The dependencies are what
    :func:`symbolic.spec.load` records: the modules the spec imports from its own folder
    tree and the data files it names with ``System.depends_on``. No absolute path is part
    of the hash, so moving the spec's folder as a whole changes nothing; without
    dependencies the hash is what it was before they were tracked."""
    h = hashlib.sha256()
    for part in (b"cbfgen-spec", inputs_hash(repo_root).encode(), spec, runtime_crate.encode()):
        h.update(part)
        h.update(b"\0")
    deps = dict(dependencies or {})
    for rel in sorted(deps, key=lambda r: r.encode()):
        h.update(rel.encode())
        h.update(b"\0")
        h.update(deps[rel])
        h.update(b"\0")
    return h.hexdigest()
