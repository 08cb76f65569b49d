"""``python -m symbolic <command>``: the symbolic stage's command line.

* ``generate SPEC --out DIR [--runtime-crate cbfgen] [--check]`` writes ``DIR/<system>.rs``
  from a spec file (see :mod:`symbolic.spec` and :mod:`symbolic.codegen.generate`).

The repository's own generated files (the core's ``generated/`` and each built-in system
crate's) are written by ``python -m symbolic.generate``.
"""

from __future__ import annotations

import argparse
import sys
import traceback
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
    except Exception as exc:  # every failure, the spec's own bugs too, is reported with its line
        if not isinstance(exc, SpecError):
            traceback.print_exception(exc)  # the whole story, above the one-line summary
        # The last line is what a build script reports: where, then what.
        print(f"error: {failure(exc, args.spec)}", file=sys.stderr)
        return 2


def failure(exc: BaseException, spec: Path) -> str:
    """One line for a spec that could not be generated: where (``file:line: ``, when
    known), then what (a bug's exception type before its message; a SpecError's message
    alone)."""
    from .spec import SpecError

    origin = spec_origin(exc, spec)
    at = f"{origin[0]}:{origin[1]}: " if origin else ""
    kind = "" if isinstance(exc, SpecError) else f"{type(exc).__name__}: "
    return f"{at}{kind}{exc}"


def spec_origin(exc: BaseException, spec: Path) -> tuple[str, int] | None:
    """``(file, line)`` in the spec's folder where ``exc`` was raised (the innermost frame
    of the spec or a module beside it), else the origin a SpecError carries (the family's
    declaration); None when neither is known."""
    folder = spec.resolve().parent
    inside = [f for f in traceback.extract_tb(exc.__traceback__)
              if Path(f.filename).resolve().is_relative_to(folder)]
    if inside:
        return inside[-1].filename, inside[-1].lineno
    return getattr(exc, "origin", None)


if __name__ == "__main__":
    sys.exit(main())
