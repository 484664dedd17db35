"""``photomodel experiment``: the accuracy study (paper secs. 3-4), resumable, local or on Dask."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from photomodel.errors import InputError


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "experiment", help="run the accuracy study: many recognitions, Table 1, figures",
        description="Run locate on many simulated scenes (or on a dataset directory) and record "
                    "every trial to DIR/records.csv, with DIR/summary.json and a report. "
                    "Rerunning the same command resumes an interrupted run.")
    p.add_argument("--out", required=True, type=Path, help="run directory (created or resumed)")
    p.add_argument("--garments", default="all", help="comma-separated catalogue names or 'all'")
    p.add_argument("--trials", type=int, default=1000,
                   help="trials per garment and condition (default 1000, as the paper)")
    p.add_argument("--conditions", default="paper", help="comma-separated simulated conditions")
    p.add_argument("--seed", type=int, default=0, help="seed of scenes and searches")
    p.add_argument("--dataset", type=Path, default=None,
                   help="evaluate the scenes of this dataset directory instead of simulating")
    p.add_argument("--workers", type=int, default=None,
                   help="local processes (default: all cores)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on a Dask distributed scheduler, e.g. tcp://host:8786")
    p.add_argument("--fitness", default="soft", help="fitness (soft, balanced, paper)")
    p.add_argument("--optimizer", choices=("ga", "full", "rga", "cma", "de"), default="ga")
    p.add_argument("--no-refine", action="store_true", help="skip the local refinement")
    p.add_argument("--paper", action="store_true",
                   help="the paper's method: paper fitness, plain binary GA, no refinement")
    p.add_argument("--generations", type=int, default=None,
                   help="cap on GA generations per run (quick studies)")
    p.add_argument("--focus", default="No.3",
                   help="garment of the report's Table 1, histograms and fitness map")
    p.add_argument("--no-report", action="store_true", help="only record the trials")
    p.set_defaults(run=run)


def _split(text: str) -> tuple[str, ...]:
    return tuple(t.strip() for t in text.split(",") if t.strip())


def run(args: argparse.Namespace) -> int:
    from photomodel.cli._progress import count_progress
    from photomodel.experiments import ExperimentConfig, run_experiment
    from photomodel.sim import garment_names, parse_conditions

    if args.trials < 1:
        raise InputError("--trials", f"expected at least 1, got {args.trials}")
    if args.workers is not None and args.workers < 1:
        raise InputError("--workers", f"expected at least 1, got {args.workers}")
    garments = garment_names() if args.garments == "all" else _split(args.garments)
    conditions = _split(args.conditions)
    if args.dataset is None:
        unknown = [g for g in garments if g not in garment_names()]
        if unknown or not garments:
            raise InputError("--garments", f"unknown garment {unknown[0] if unknown else ''!r}; "
                                           f"the catalogue has {', '.join(garment_names())}")
        for spec in conditions:
            try:
                parse_conditions(spec)
            except ValueError as exc:
                raise InputError("--conditions", str(exc)) from None
    elif not args.dataset.is_dir():
        raise InputError(args.dataset, "dataset directory not found")
    config = ExperimentConfig(
        garments=tuple(garments) if args.dataset is None else (),
        conditions=conditions if args.dataset is None else (),
        trials=args.trials if args.dataset is None else 0, seed=args.seed,
        fitness=args.fitness, optimizer=args.optimizer, refine=not args.no_refine,
        paper=args.paper, max_generations=args.generations,
        dataset=None if args.dataset is None else os.fspath(args.dataset.resolve()))
    try:
        with count_progress("trials", sys.stderr.isatty()) as progress:
            summary = run_experiment(args.out, config, workers=args.workers,
                                     scheduler=args.scheduler, progress=progress)
    except KeyboardInterrupt:
        print(f"photomodel: interrupted; finished trials are in {args.out / 'records.csv'}; "
              "run the same command again to continue", file=sys.stderr)
        return 130
    except ValueError as exc:
        raise InputError(args.out, str(exc)) from None
    print(f"{args.out}/records.csv: {summary['trials_total']} trials "
          f"({summary['trials_this_run']} run now on {summary['executor']} in "
          f"{summary['wall_seconds_this_run']:.0f} s)")
    if not args.no_report:
        from photomodel.experiments import write_experiment_report

        report = write_experiment_report(args.out, focus=args.focus)
        print(f"report: {report}")
    return 0
