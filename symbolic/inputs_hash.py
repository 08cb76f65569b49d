"""The hash of everything generation reads; build.rs recomputes it the same way.

A system generated from a spec file (``python -m symbolic generate SPEC``) records
:func:`spec_inputs_hash` instead: the package hash below, the spec file's bytes and
the runtime crate path, so a build helper can tell a stale file from a current one.

Rule (mirrored in build.rs - keep the two in step): every file under ``symbolic/``
whose name ends in .py, .toml or .txt, skipping directories named ``tests``,
``__pycache__`` or starting with a dot. Files are taken in byte order of their
'/'-separated path relative to the repository root; the hash is SHA-256 over, for each
file, ``path`` + NUL + contents + NUL.
"""

from __future__ import annotations

import hashlib
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


def spec_inputs_hash(repo_root: Path, spec: bytes, runtime_crate: str) -> str:
    """SHA-256 over ``"cbfgen-spec"`` NUL, :func:`inputs_hash` (hex) NUL, the spec
    file's bytes NUL, ``runtime_crate`` NUL. The spec's path is not part of it, so moving
    the file changes nothing; modules the spec imports besides ``symbolic`` are not
    either (keep a spec self-contained)."""
    h = hashlib.sha256()
    for part in (b"cbfgen-spec", inputs_hash(repo_root).encode(), spec, runtime_crate.encode()):
        h.update(part)
        h.update(b"\0")
    return h.hexdigest()
