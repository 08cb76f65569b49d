"""What every generated Rust file shares: where the generator lives (its rustfmt.toml and
the root that spec labels and input hashes are relative to), the hash header line, and
rustfmt. The bottom of the code generator: it imports nothing of it."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

# The folder holding symbolic/ (the repository root in a checkout).
REPO_ROOT = Path(__file__).resolve().parent.parent.parent
HASH_PREFIX = "// inputs-sha256: "


def rustfmt(text: str, repo_root: Path = REPO_ROOT) -> str:
    """``text`` formatted by rustfmt with the repository's rustfmt.toml, so generated code
    passes the same ``cargo fmt --check`` as the hand-written code. rustfmt ships with
    every rustup toolchain; its absence stops generation with the fix named."""
    exe = shutil.which("rustfmt")
    if exe is None:
        raise SystemExit("symbolic.generate: rustfmt not found on PATH; install it with "
                         "'rustup component add rustfmt'")
    done = subprocess.run([exe, "--edition", "2021", "--config-path", str(repo_root / "rustfmt.toml")],
                          input=text, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"symbolic.generate: rustfmt rejected the generated code:\n{done.stderr}")
    return done.stdout
