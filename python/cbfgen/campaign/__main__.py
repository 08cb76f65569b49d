"""``python -m cbfgen.campaign``: a campaign or a falsifier on any scenario and engine.

    python -m cbfgen.campaign run --scenario stairs --episodes 1000 --engine ray
    python -m cbfgen.campaign falsify --scenario stairs --budget 200 --compare-uniform

Scenarios: ``stairs`` and ``perceived-stairs`` (Tachyon 3, as ``cbfgen campaign``),
``arm`` (the Panda among random obstacles), or a class of your own as
``path/to/file.py:ClassName`` or ``package.module:ClassName`` (constructed without
arguments). ``--range NAME=LO,HI`` narrows a built-in scenario's parameter.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import importlib
import importlib.util
import sys
import time
from pathlib import Path

import numpy as np

from .engine import Engine, run_campaign
from .falsifier import Falsification, falsify
from .scenario import Row, Scenario
from .scenarios import ArmObstacles, TachyonStairs


def scenario_from(name: str, ranges: list[str], ray: bool = False) -> Scenario:
    """The scenario named on the command line, with its ``--range`` overrides; with
    ``ray``, a class from a file is shipped to Ray's workers by value (they cannot import
    the file by name)."""
    spans: dict[str, list[float]] = {}
    for text in ranges:
        key, _, span = text.partition("=")
        try:
            lo, hi = (float(v) for v in span.split(","))
        except ValueError:
            raise SystemExit(f"--range {text!r} is not NAME=LO,HI") from None
        spans[key] = [lo, hi]
    if name in ("stairs", "perceived-stairs"):
        return TachyonStairs(ranges=spans, perception=name == "perceived-stairs")
    if name == "arm":
        unknown = set(spans) - {"obstacles", "cruise_speed"}
        if unknown:
            raise SystemExit(f"no arm range {', '.join(sorted(unknown))}; known: obstacles, cruise_speed")
        obstacles = [int(v) for v in spans.get("obstacles", (5, 25))]
        return ArmObstacles(obstacles=obstacles, cruise_speed=spans.get("cruise_speed", (0.4, 1.2)))
    if ":" not in name:
        raise SystemExit(f"unknown scenario {name!r}: stairs, perceived-stairs, arm, or FILE.py:CLASS / MODULE:CLASS")
    if spans:
        raise SystemExit("--range narrows only the built-in scenarios; set your scenario's parameters in its class")
    where, _, cls = name.rpartition(":")
    if where.endswith(".py"):
        path = Path(where).resolve()
        spec = importlib.util.spec_from_file_location(path.stem, path)
        if spec is None or spec.loader is None:
            raise SystemExit(f"cannot load {where}")
        module = importlib.util.module_from_spec(spec)
        # Registered under its name, so that engines in forked workers unpickle it.
        sys.modules[path.stem] = module
        spec.loader.exec_module(module)
        if ray:
            from ray import cloudpickle

            cloudpickle.register_pickle_by_value(module)
    else:
        module = importlib.import_module(where)
    scenario = getattr(module, cls, None)
    if not (isinstance(scenario, type) and issubclass(scenario, Scenario)):
        raise SystemExit(f"{name}: {cls} is not a cbfgen.campaign.Scenario subclass")
    return scenario()


def engine_from(name: str, workers: int | None) -> Engine:
    """``none``, ``threads``, ``processes``, ``ray`` or a Ray address."""
    if name == "none":
        return None
    if name == "threads":
        return concurrent.futures.ThreadPoolExecutor(workers)
    if name == "processes":
        return concurrent.futures.ProcessPoolExecutor(workers)
    if name == "ray" and workers is not None:
        import ray

        ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
    return name


def progress(done: int, total: int) -> None:
    print(f"\r{done}/{total} episodes", end="" if done < total else "\n", file=sys.stderr, flush=True)


def write_rows(scenario: Scenario, rows: list[Row], out: Path) -> list[Path]:
    """Rows in the generic CSV and report (not a built-in scenario's own files, which
    assume a campaign's ids): the falsifier's searched, sampled and uniform episodes."""
    return Scenario.write(scenario, rows, out)


def running_worst_figure(result: Falsification, uniform: list[Row] | None, path: Path) -> Path:
    """The worst value found against episodes spent: the falsifier's search and estimate,
    and uniform sampling's at the same budget, with the failure threshold."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    m, scenario = result.measure, result.scenario

    def running(rows: list[Row]) -> np.ndarray:
        worst = np.minimum.accumulate([m.badness(scenario.value(r, m)) for r in rows])
        return np.where(np.isfinite(worst), worst if m.worse == "lower" else -worst, np.nan)

    fig, ax = plt.subplots(figsize=(7, 4))
    found = running(result.search + result.sampled)
    ax.step(np.arange(1, len(found) + 1), found, where="post", label="falsifier (CMA-ES, then importance sampling)")
    ax.axvline(len(result.search) + 0.5, color="#999", lw=0.8, ls=":")
    if uniform:
        ax.step(np.arange(1, len(uniform) + 1), running(uniform), where="post", label="uniform sampling")
    threshold = m.fails_below if m.worse == "lower" else m.fails_above
    ax.axhline(threshold, color="#d62728", ls="--", lw=1, label="failure threshold")
    ax.set(xlabel="episodes run", ylabel=f"worst {m.column} so far", title=f"{scenario.name}: worst {m.column}")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m cbfgen.campaign", description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    for name, text in (("run", "a campaign of episodes drawn from a seed"), ("falsify", "hunt for the worst episode")):
        sub = commands.add_parser(name, help=text)
        sub.add_argument("--scenario", default="stairs", help="stairs, perceived-stairs, arm, FILE.py:CLASS")
        sub.add_argument("--range", action="append", default=[], metavar="NAME=LO,HI", help="narrow a parameter")
        sub.add_argument("--seed", type=int, default=0)
        sub.add_argument(
            "--engine", default="none", help="none (this process), threads, processes, ray, or a Ray address"
        )
        sub.add_argument("--workers", type=int, default=None, help="workers of threads/processes/a local Ray")
        sub.add_argument("--out", type=Path, default=Path(f"out/campaign_{name}"))
    run = commands.choices["run"]
    run.add_argument("--episodes", type=int, default=200)
    run.add_argument("--first-id", type=int, default=0)
    run.add_argument("--shards", type=int, default=None, help="default: 1 in this process, 4 per worker")
    fal = commands.choices["falsify"]
    fal.add_argument("--measure", default=None, help="a measure's column (default: the scenario's first)")
    fal.add_argument("--budget", type=int, default=200, help="episodes in all (search and estimate)")
    fal.add_argument("--compare-uniform", action="store_true", help="also run a uniform campaign of the budget")
    args = parser.parse_args(argv)

    scenario = scenario_from(args.scenario, args.range, ray=args.engine not in ("none", "threads", "processes"))
    engine = engine_from(args.engine, args.workers)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.command == "run":
        campaign = run_campaign(
            scenario,
            args.episodes,
            seed=args.seed,
            first_id=args.first_id,
            engine=engine,
            shards=args.shards,
            progress=progress,
        )
        print(campaign.report())
        print(
            f"{args.episodes} episodes in {campaign.seconds:.1f} s wall on {campaign.engine}, {campaign.shards} shards"
        )
        written = campaign.write(args.out)
    else:
        started = time.perf_counter()
        result = falsify(scenario, args.measure, budget=args.budget, seed=args.seed, engine=engine, progress=progress)
        text = result.report()
        written = [
            *write_rows(scenario, result.search, args.out / "search"),
            *write_rows(scenario, result.sampled, args.out / "sampled"),
        ]
        if args.compare_uniform:
            uniform = run_campaign(scenario, args.budget, seed=args.seed, engine=engine, progress=progress)
            m = result.measure
            (worst,) = scenario.worst(uniform.rows, m)
            failed = uniform.failures(m.column)  # ids from 0: the k-th episode run is id k - 1
            text += (
                f"\nuniform sampling, {args.budget} episodes of seed {args.seed}: worst {m.column} = "
                f"{scenario.value(worst, m)} (episode {worst['id']}); "
                + (f"first failure at episode {failed[0] + 1}, {len(failed)} in all" if failed else "no failure")
            )
            written += write_rows(scenario, uniform.rows, args.out / "uniform")
        written.append(
            running_worst_figure(result, uniform.rows if args.compare_uniform else None, args.out / "falsification.png")
        )
        text += f"\n{time.perf_counter() - started:.1f} s wall"
        print(text)
        (args.out / "falsification.txt").write_text(text + "\n")
        written.append(args.out / "falsification.txt")
    print("wrote " + ", ".join(str(p) for p in written))
    return 0


def entry() -> int:
    """:func:`main`, with a refused setting as one line (status 2) instead of a traceback."""
    try:
        return main()
    except (ValueError, TypeError) as refused:
        print(f"error: {refused}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(entry())
