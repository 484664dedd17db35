"""``photomodel experiment``: the accuracy study (paper secs. 3-4), resumable, local or on Dask."""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from photomodel.errors import InputError

MAX_TRIALS = 100_000
"""Most trials per garment and condition (the paper's study is 1000)."""
MAX_WORKERS = 1024
MAX_GENERATIONS = 100_000
_OPTIONS = {"trials": "--trials", "seed": "--seed", "max_generations": "--generations",
            "fitness": "--fitness", "optimizer": "--optimizer", "library": "--library",
            "max_candidates": "--max-candidates", "min_score": "--min-score",
            "negative_trials": "--negative-trials", "garments": "--garments",
            "conditions": "--conditions"}


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "experiment", help="run the accuracy study: many recognitions, Table 1, figures",
        description="Run locate on many simulated scenes (or on a dataset directory) and record "
                    "every trial to DIR/records.csv, with DIR/summary.json and a report. "
                    "Rerunning the same command resumes an interrupted run.")
    p.add_argument("--out", required=True, type=Path, help="run directory (created or resumed)")
    p.add_argument("--garments", default="all", help="comma-separated catalogue names or 'all'")
    p.add_argument("--trials", type=int, default=1000,
                   help=f"trials per garment and condition, 1 to {MAX_TRIALS} (default 1000, "
                        "as the paper)")
    p.add_argument("--conditions", default="paper", help="comma-separated simulated conditions")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of scenes and searches, 0 to 4294967295 (default 0)")
    p.add_argument("--dataset", type=Path, default=None,
                   help="evaluate the scenes of this dataset directory instead of simulating")
    p.add_argument("--workers", type=int, default=None,
                   help="local processes (default: all cores)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on a Dask distributed scheduler, e.g. tcp://host:8786")
    p.add_argument("--fitness", choices=("soft", "balanced", "paper"), default="soft",
                   help="fitness (default soft)")
    p.add_argument("--optimizer", choices=("ga", "full", "rga", "cma", "de"), default="ga")
    p.add_argument("--no-refine", action="store_true", help="skip the local refinement")
    p.add_argument("--paper", action="store_true",
                   help="the paper's method: paper fitness, plain binary GA, no refinement")
    p.add_argument("--generations", type=int, default=None,
                   help=f"cap on GA generations per run, 1 to {MAX_GENERATIONS} (quick "
                        "studies)")
    p.add_argument("--focus", default="No.3",
                   help="garment of the report's Table 1, histograms and fitness map")
    p.add_argument("--no-report", action="store_true", help="only record the trials")
    g = p.add_argument_group(
        "identification (--identify)",
        "identify a library's models on scenes with one of them (--garments, --conditions, "
        "--trials), on empty scenes and on scenes with other things only (--negatives); "
        "writes identify.csv, identify_summary.json, identify_report.md and confusion.png")
    g.add_argument("--identify", action="store_true",
                   help="run the identification experiment instead of the accuracy study")
    g.add_argument("--library", default=None,
                   help="garments whose models form the library (names or groups; default: "
                        "--garments)")
    g.add_argument("--negatives", default="empty,no-target",
                   help="conditions without a library garment (default: empty,no-target)")
    g.add_argument("--negative-trials", type=int, default=10,
                   help="scenes per negative condition (default 10)")
    g.add_argument("--max-candidates", type=int, default=3,
                   help="models searched per scene after the colour screen (default 3)")
    g.add_argument("--min-score", type=float, default=None,
                   help="threshold applied (default: the stored, calibrated one)")
    g.add_argument("--calibrate", action="store_true",
                   help="calibrate the threshold on this run's records and write it to the "
                        "user's threshold file (~/.config/photomodel/threshold.json, or "
                        "$PHOTOMODEL_THRESHOLD), which locate and identify then read")
    g.add_argument("--threshold-file", type=Path, default=None,
                   help="with --calibrate: write the threshold here instead (e.g. a model "
                        "library's threshold.json)")
    p.set_defaults(run=run)


def _split(text: str) -> tuple[str, ...]:
    return tuple(t.strip() for t in text.split(",") if t.strip())


def _check_common(args: argparse.Namespace) -> None:
    """The options both experiments share: one line naming the option and its range."""
    from photomodel.cli._options import check_int, check_scheduler, check_seed

    check_seed(args.seed)
    if args.workers is not None:
        check_int("--workers", args.workers, 1, MAX_WORKERS)
    if args.generations is not None:
        check_int("--generations", args.generations, 1, MAX_GENERATIONS)
    if args.scheduler is not None:
        args.scheduler = check_scheduler(args.scheduler)


@contextlib.contextmanager
def _run_directory(out: Path, files: tuple[str, ...]) -> Iterator[None]:
    """Hold ``out``'s run lock around a run and its report (a second run into ``out`` is
    refused); a directory made here that got no record is removed again on failure."""
    from photomodel.experiments import run_directory

    with run_directory(out, files):
        yield


def run(args: argparse.Namespace) -> int:
    from photomodel.cli._options import as_option_error, check_int
    from photomodel.cli._progress import count_progress
    from photomodel.experiments import ExperimentConfig, run_experiment
    from photomodel.sim import expand_garments, garment_names, parse_conditions

    _check_common(args)
    if args.identify:
        return run_identify(args)
    check_int("--trials", args.trials, 1, MAX_TRIALS)
    try:
        garments = expand_garments(args.garments) if args.dataset is None else ()
    except ValueError as exc:
        raise InputError("--garments", str(exc)) from None
    conditions = _split(args.conditions)
    if args.dataset is None:
        if not garments:
            raise InputError("--garments", f"no garment named; the catalogue has "
                                           f"{', '.join(garment_names())}")
        for spec in conditions:
            try:
                parse_conditions(spec)
            except ValueError as exc:
                raise InputError("--conditions", str(exc)) from None
    elif not args.dataset.is_dir():
        raise InputError(args.dataset, "dataset directory not found")
    try:
        config = ExperimentConfig(
            garments=tuple(garments) if args.dataset is None else (),
            conditions=conditions if args.dataset is None else (),
            trials=args.trials if args.dataset is None else 0, seed=args.seed,
            fitness=args.fitness, optimizer=args.optimizer, refine=not args.no_refine,
            paper=args.paper, max_generations=args.generations,
            dataset=None if args.dataset is None else os.fspath(args.dataset.resolve()))
    except ValueError as exc:
        raise as_option_error(exc, _OPTIONS, "experiment") from None
    with _run_directory(args.out, ("config.json", "summary.json")):
        try:
            with count_progress("trials", sys.stderr.isatty()) as progress:
                summary = run_experiment(args.out, config, workers=args.workers,
                                         scheduler=args.scheduler, progress=progress)
        except KeyboardInterrupt:
            print(f"photomodel: interrupted; finished trials are in "
                  f"{args.out / 'records.csv'}; run the same command again to continue",
                  file=sys.stderr)
            return 130
        except ValueError as exc:   # an InputError (names its file) passes unchanged
            raise as_option_error(exc, _OPTIONS, str(args.out)) from None
        print(f"{args.out}/records.csv: {summary['trials_total']} trials "
              f"({summary['trials_this_run']} run now on {summary['executor']} in "
              f"{summary['wall_seconds_this_run']:.0f} s)")
        if not args.no_report:
            from photomodel.experiments import write_experiment_report

            report = write_experiment_report(args.out, focus=args.focus)
            print(f"report: {report}")
    return 0


def run_identify(args: argparse.Namespace) -> int:
    """``experiment --identify``: the identification experiment (and, with ``--calibrate``,
    the threshold calibration)."""
    from photomodel.cli._options import as_option_error, check_float, check_int
    from photomodel.cli._progress import count_progress
    from photomodel.experiments import IdentifyExperimentConfig, run_identify_experiment
    from photomodel.sim import expand_garments, parse_conditions

    if args.dataset is not None:
        raise InputError("--dataset", "--identify runs on simulated scenes only")
    if args.scheduler is not None:
        raise InputError("--scheduler", "--identify runs on local processes only")
    check_int("--trials", args.trials, 0, MAX_TRIALS)
    check_int("--negative-trials", args.negative_trials, 0, MAX_TRIALS)
    check_int("--max-candidates", args.max_candidates, 1, 1000)
    if args.min_score is not None:
        check_float("--min-score", args.min_score, 0.0, 1.0)
    try:
        garments = expand_garments(args.garments)
        library = expand_garments(args.library) if args.library is not None else garments
    except ValueError as exc:
        raise InputError("--garments/--library", str(exc)) from None
    unknown = [g for g in garments if g not in library]
    if unknown:
        raise InputError("--library", f"has no model of {unknown[0]!r}, which --garments lays "
                                      "on the table")
    conditions, negatives = _split(args.conditions), _split(args.negatives)
    for option, specs, target in (("--conditions", conditions, True),
                                  ("--negatives", negatives, False)):
        for spec in specs:
            try:
                has_target = parse_conditions(spec).target
            except ValueError as exc:
                raise InputError(option, str(exc)) from None
            if has_target != target:
                raise InputError(option, f"{spec!r} {'has no' if target else 'has a'} target "
                                         "garment")
    try:
        config = IdentifyExperimentConfig(
            library=library, garments=garments, conditions=conditions, trials=args.trials,
            negatives=negatives, negative_trials=args.negative_trials, seed=args.seed,
            max_candidates=args.max_candidates,
            min_score=None if args.calibrate else args.min_score)
    except ValueError as exc:
        raise as_option_error(exc, _OPTIONS, "--identify") from None
    if args.calibrate:
        # Decisions need a threshold before the stored one exists: summarise at 0.5 first.
        config = IdentifyExperimentConfig(**{**config.__dict__, "min_score": 0.5})
    with _run_directory(args.out, ("identify_config.json",)):
        try:
            with count_progress("scenes", sys.stderr.isatty()) as progress:
                summary = run_identify_experiment(args.out, config, workers=args.workers,
                                                  progress=progress)
        except KeyboardInterrupt:
            print(f"photomodel: interrupted; finished scenes are in "
                  f"{args.out / 'identify.csv'}; run the same command again to continue",
                  file=sys.stderr)
            return 130
        except ValueError as exc:   # an InputError (names its file) passes unchanged
            raise as_option_error(exc, _OPTIONS, str(args.out)) from None
        return _finish_identify(args, config, summary)


def _finish_identify(args: argparse.Namespace, config: Any, summary: dict[str, Any]) -> int:
    """Calibrate (``--calibrate``) and print the identification experiment's summary."""
    if args.calibrate:
        from photomodel.experiments import calibrate_from_records, write_identify_report
        from photomodel.locate import save_threshold

        command = "photomodel " + " ".join(sys.argv[1:]) if sys.argv else ""
        threshold = calibrate_from_records(args.out, command=command)
        path = save_threshold(threshold, args.threshold_file)
        print(f"threshold min_score = {threshold.min_score:.4f} stored in {path}")
        summary = write_identify_report(args.out, config, min_score=threshold.min_score)

    def pct(x: float | None) -> str:
        return "n/a" if x is None else f"{100 * x:.1f} %"

    print(f"{args.out}/identify.csv: {summary['garment_scenes']} garment scenes, "
          f"{summary['negative_scenes']} without; top-1 {pct(summary['top1'])}, rejected "
          f"{pct(summary['rejection_rate'])}, false acceptance {pct(summary['false_accept'])} "
          f"at min_score {summary['min_score']:.3f}")
    print(f"report: {args.out / 'identify_report.md'}")
    return 0
