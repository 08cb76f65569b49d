"""The Python module's build (maturin selects cbfgen-python alone) and the workspace's
build (every member) must resolve the same features for every dependency they share:
a feature that differs changes the hash of every crate above it, and `scripts/cbf test`
would compile the core and every system twice (see feature_union/Cargo.toml)."""

from __future__ import annotations

import shutil
import subprocess
from collections import defaultdict
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(shutil.which("cargo") is None, reason="reads the build graph with cargo tree")


def resolved_features(*selection: str) -> dict[str, set[str]]:
    """Package (name and version) -> the feature lists cargo resolves for it in a build of
    ``selection`` (one list per host or target build of the package)."""
    out = subprocess.run(["cargo", "tree", "--offline", "--prefix", "none", "--format", "{p}|{f}", *selection],
                         cwd=REPO_ROOT, check=True, capture_output=True, text=True).stdout
    features: dict[str, set[str]] = defaultdict(set)
    for line in out.splitlines():
        package, _, feats = line.partition("|")
        if not package.strip():
            continue
        name, version = package.split()[:2]
        features[f"{name} {version}"].add(feats.split(" (")[0].strip())
    return features


def test_the_python_module_and_the_workspace_build_shared_crates_with_the_same_features():
    python = resolved_features("-p", "cbfgen-python", "--edges", "normal,build")
    # Not capi: its cbindgen builds syn for the target (the header generator), a build of
    # syn nothing else has and the Python module never makes, so it shares nothing with it.
    workspace = resolved_features("--workspace", "--exclude", "cbfgen-python", "--exclude", "cbfgen-capi")
    shared = sorted(set(python) & set(workspace))
    assert "cbfgen v0.1.0" in shared and any(p.startswith("nalgebra ") for p in shared)
    differ = {p: (sorted(python[p]), sorted(workspace[p])) for p in shared if python[p] != workspace[p]}
    assert not differ, ("features differ between the Python module's build and the workspace's (add the union to "
                        f"feature_union/Cargo.toml): {differ}")
