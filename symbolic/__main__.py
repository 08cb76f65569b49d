"""``python -m symbolic <command>``: the symbolic stage's command line.

* ``generate SPEC --out DIR [--runtime-crate cbfgen] [--check]`` writes ``DIR/<system>.rs``
  from a spec file (see :mod:`symbolic.spec` and :mod:`symbolic.codegen.generate`).

The repository's own generated files (the core's ``generated/`` and each built-in system
crate's) are written by ``python -m symbolic.generate``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m symbolic", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    commands = parser.add_subparsers(dest="command", required=True)
    gen = commands.add_parser("generate", help="generate a system's Rust module from a spec file")
    gen.add_argument("spec", type=Path, help="the spec file (Python, defining build() -> System)")
    gen.add_argument("--out", type=Path, required=True, help="directory to write <system>.rs into")
    gen.add_argument("--runtime-crate", default="cbfgen",
                     help="path of the cbfgen runtime in the generated code: `cbfgen` (default) from "
                          "another crate, `crate` inside cbfgen")
    gen.add_argument("--check", action="store_true",
                     help="write nothing; exit 1 if the file differs from a fresh generation")
    args = parser.parse_args(argv)

    from .codegen.generate import generate
    from .spec import SpecError

    try:
        return generate(args.spec, args.out, args.runtime_crate, args.check)
    except SpecError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
