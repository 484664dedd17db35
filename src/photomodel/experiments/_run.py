"""Running an experiment: trials spread over local processes or a Dask cluster, resumable.

Each finished trial is appended to ``records.csv`` at once (and flushed), so an interrupted run
loses at most the trials in flight; running the same command again skips the recorded trials.
``config.json`` pins the settings of a run directory: resuming with other settings is refused,
except more trials per garment, which extends the study (trial ids and seeds do not depend on
the number of trials, so the recorded ones stay valid).

One run at a time writes a run directory (:func:`~photomodel.experiments._lock.run_lock`: a
second one is refused, naming the first one's pid), and the worker processes end with the run
that started them, even when it is killed (``kill -9``): a killed run leaves neither duplicated
records nor orphaned workers, and rerunning it resumes.
"""

from __future__ import annotations

import contextlib
import json
import os
import platform
import subprocess
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from pathlib import Path
from typing import Any

from photomodel._files import write_atomic
from photomodel._process import die_with_parent
from photomodel.errors import InputError, one_line_input_warnings
from photomodel.experiments._lock import LOCK_NAME, run_lock
from photomodel.experiments._records import append_records, done_trial_ids
from photomodel.experiments._trials import (
    ExperimentConfig,
    Trial,
    limit_threads,
    plan_trials,
    run_trial,
)

__all__ = ["RunSummary", "run_directory", "run_experiment", "run_metadata"]

RunSummary = dict[str, Any]
Progress = Callable[[int, int, str], None]

_PACKAGES = ("numpy", "numba", "opencv-python-headless", "scipy", "scikit-image", "photomodel")


def _commit() -> str:
    here = Path(__file__).resolve().parent
    try:
        return subprocess.run(["git", "-C", str(here), "rev-parse", "HEAD"], capture_output=True,
                              text=True, check=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def run_metadata() -> dict[str, Any]:
    """Commit, library versions and machine of this run."""
    from importlib.metadata import PackageNotFoundError, version

    versions = {}
    for p in _PACKAGES:
        try:
            versions[p] = version(p)
        except PackageNotFoundError:
            versions[p] = None
    return {"commit": _commit(), "versions": versions,
            "machine": {"platform": platform.platform(), "processor": platform.processor(),
                        "cpus": os.cpu_count(), "python": platform.python_version()}}


def read_json(path: Path) -> Any:
    """The JSON value of a run's file ``path``; a clear error when it cannot be read."""
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(path, f"cannot read: {exc}") from None


def config_changes(path: Path, wanted: dict[str, Any],
                   ignore: tuple[str, ...] = ()) -> list[str] | None:
    """Keys whose values in the run's stored config ``path`` differ from ``wanted`` (sorted,
    ``ignore`` left out), or None when no config is stored yet."""
    if not path.exists():
        return None
    found = read_json(path)
    return sorted(k for k in set(found) | set(wanted)
                  if found.get(k) != wanted.get(k) and k not in ignore)


def write_json(path: Path, data: dict[str, Any]) -> None:
    """Write one of a run's JSON files (config, summary, runs) atomically
    (:func:`~photomodel._files.write_atomic`)."""
    write_atomic(path, (json.dumps(data, indent=1) + "\n").encode())


def _check_config(out: Path, config: ExperimentConfig) -> None:
    path = out / "config.json"
    wanted = config.to_json_dict()
    diff = config_changes(path, wanted)
    if diff is not None:
        found_trials = json.loads(path.read_text()).get("trials") if diff == ["trials"] else 0
        grows = diff == ["trials"] and int(wanted["trials"]) > int(found_trials or 0)
        if diff and not grows:
            raise InputError(out, "holds an experiment with other settings "
                                  f"({', '.join(diff)}); choose another --out to start afresh")
        if not grows:
            return
    write_json(path, wanted)


def _in_process(config: ExperimentConfig, trials: list[Trial]) -> Iterator[dict[str, Any]]:
    for trial in trials:
        yield run_trial(config, trial)


def pool_stream(run: Callable[[Any, Any], dict[str, Any]], config: Any, trials: Sequence[Any],
                workers: int) -> Iterator[dict[str, Any]]:
    """``run(config, trial)`` for every trial in a local process pool, yielded as they finish.

    Workers are spawned (no inherited numba threads), limited by
    :func:`~photomodel.experiments._trials.limit_threads` and end when this process ends,
    however it ends (:func:`~photomodel._process.die_with_parent`); leaving the loop
    early cancels the trials not yet started.
    """
    with ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn"),
                             initializer=init_worker, initargs=(os.getpid(),)) as pool:
        futures = [pool.submit(run, config, t) for t in trials]
        try:
            for fut in as_completed(futures):
                yield fut.result()
        finally:
            for fut in futures:
                fut.cancel()


def init_worker(parent_pid: int) -> None:
    """Initialiser of a pool worker: end with the parent ``parent_pid``, one numba thread,
    input warnings printed as the CLI prints them (one line)."""
    die_with_parent(parent_pid)
    warnings.showwarning = one_line_input_warnings()
    limit_threads()


SCHEDULER_TIMEOUT_S = 5.0
"""How long to try to reach a Dask scheduler before giving up."""


def connect_scheduler(scheduler: Any) -> Any:
    """A ``distributed.Client`` of ``scheduler`` (an address or a client, returned as is).

    Raises
    ------
    InputError
        Dask is not installed, or no scheduler answers at the address within
        :data:`SCHEDULER_TIMEOUT_S` (the message names ``--scheduler``).
    """
    try:
        from distributed import Client
    except ImportError:
        raise InputError("--scheduler", "needs Dask: pip install 'photomodel[cluster]'") from None
    if isinstance(scheduler, Client):
        return scheduler
    try:
        return Client(scheduler, timeout=f"{SCHEDULER_TIMEOUT_S:g}s")
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise InputError("--scheduler", f"cannot reach a Dask scheduler at {scheduler!r} "
                                        f"({reason})") from None


def _dask(config: ExperimentConfig, trials: list[Trial],
          client: Any, own: bool) -> Iterator[dict[str, Any]]:
    from distributed import as_completed as dask_completed

    try:
        futures = client.map(run_trial, [config] * len(trials), trials, pure=False)
        try:
            for fut in dask_completed(futures):
                yield fut.result()
        finally:
            client.cancel(futures)
    finally:
        if own:
            client.close()


def run_experiment(
    out: str | os.PathLike[str],
    config: ExperimentConfig,
    *,
    workers: int | None = None,
    scheduler: Any = None,
    progress: Progress | None = None,
) -> RunSummary:
    """Run (or resume) an experiment into ``out``: ``records.csv``, ``config.json``,
    ``summary.json``.

    Parameters
    ----------
    out : path
        Run directory (created if needed). Trials already in its ``records.csv`` are skipped.
    config : ExperimentConfig
        Settings; must equal those the directory was started with.
    workers : int, optional
        Local processes (default: all cores; 1 runs in this process).
    scheduler : str or distributed.Client, optional
        Address of a Dask scheduler (or a client) to run the trials on instead.
    progress : callable(done, total, trial_id), optional
        Called as each trial is recorded (``done`` counts earlier runs' trials too).

    Returns
    -------
    dict
        The summary written to ``summary.json``: settings, commit, versions, machine, trial
        counts, wall time of this run and in all, the executor, and ``runs`` (trials, executor,
        wall time and commit of each run that recorded trials).
    """
    out = Path(out)
    with run_directory(out, ("config.json", "summary.json")):
        return _run(out, config, workers, scheduler, progress)


@contextlib.contextmanager
def run_directory(out: Path, files: Sequence[str]) -> Iterator[None]:
    """Create run directory ``out`` if needed and hold its run lock inside (a second run into
    ``out`` is refused); a directory made here that got no record is removed again on
    failure (:func:`remove_unused_run` with ``files``)."""
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(out, f"cannot create the run directory ({exc.strerror})") from None
    try:
        with run_lock(out):
            yield
    except BaseException:
        if created:
            remove_unused_run(out, files)
        raise


def remove_unused_run(out: Path, names: Sequence[str]) -> None:
    """Remove run directory ``out`` that a failed run created, if it holds no record: the
    files ``names`` and the lock go, then the directory if nothing else is in it."""
    if any(out.glob("*.csv")):
        return
    for name in (*names, LOCK_NAME):
        (out / name).unlink(missing_ok=True)
    with contextlib.suppress(OSError):   # not empty (someone else's files): it stays
        out.rmdir()


def _run(out: Path, config: ExperimentConfig, workers: int | None, scheduler: Any,
         progress: Progress | None) -> RunSummary:
    _check_config(out, config)
    records = out / "records.csv"
    trials = plan_trials(config)
    if not trials:
        raise InputError(out, "the experiment has no trials")
    done = done_trial_ids(records)
    pending = [t for t in trials if t.trial_id not in done]
    workers = max(1, int(workers or os.cpu_count() or 1))
    if scheduler is not None:
        client = connect_scheduler(scheduler)
        stream = _dask(config, pending, client, own=client is not scheduler)
        executor = f"dask ({scheduler})"
    elif workers == 1 or len(pending) <= 1:
        stream, executor = _in_process(config, pending), "in-process"
    else:
        stream = pool_stream(run_trial, config, pending, min(workers, len(pending)))
        executor = f"{min(workers, len(pending))} local processes"
    t0 = time.perf_counter()
    n_done = len(trials) - len(pending)
    for record in stream:
        append_records(records, [record])
        n_done += 1
        if progress is not None:
            progress(n_done, len(trials), str(record["trial_id"]))
    summary = {
        "settings": config.to_json_dict(),
        **run_metadata(),
        "trials_total": len(trials),
        "trials_this_run": len(pending),
        "wall_seconds_this_run": time.perf_counter() - t0,
        "executor": executor,
    }
    previous = out / "summary.json"
    before: dict[str, Any] = {}
    if previous.exists():
        try:
            before = json.loads(previous.read_text())
        except (OSError, ValueError):
            before = {}
    this_run = {"trials": len(pending), "executor": executor,
                "wall_seconds": summary["wall_seconds_this_run"], "commit": summary["commit"]}
    summary["runs"] = [*before.get("runs", []), this_run] if pending else before.get("runs", [])
    summary["wall_seconds_total"] = (float(before.get("wall_seconds_total", 0.0))
                                     + summary["wall_seconds_this_run"])
    write_json(previous, summary)
    return summary
