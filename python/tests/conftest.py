"""Fixtures shared by the tests that build crates from specs (cbfgen.load, cbfgen.embed)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def environment(tmp_path_factory):
    """The variables cbfgen.load and cbfgen.embed read: this clone's sources, a fresh cache
    (the module's own), and the spec-crate tests' target dir (the core compiles once)."""
    saved = {k: os.environ.get(k) for k in ("CBFGEN_SOURCE", "CBFGEN_CACHE", "CARGO_TARGET_DIR")}
    os.environ["CBFGEN_SOURCE"] = str(REPO_ROOT)
    os.environ["CBFGEN_CACHE"] = str(tmp_path_factory.mktemp("cache"))
    os.environ["CARGO_TARGET_DIR"] = str(REPO_ROOT / "target" / "spec-crates")
    yield Path(os.environ["CBFGEN_CACHE"])
    for k, v in saved.items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v
