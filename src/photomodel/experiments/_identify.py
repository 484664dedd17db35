"""The identification experiment: a library of models, scenes with one of them, with other
things only, or empty; which model ``identify`` names, and how well it places it.

Trials are pure functions of the settings and their id, as in the accuracy study: scene
``<condition>_<garment>_<index:04d>`` (or ``<condition>_<index:04d>`` without a target) is
the one ``photomodel simulate --seed`` writes, the models are built from the same model photos,
and the searches are seeded from the trial id. Every trial appends one row to
``identify.csv`` as it finishes (a rerun resumes); the decision is *not* recorded but applied
when summarising (best score >= ``min_score``), so the stored threshold can be calibrated on,
and applied to, the same records. (The threshold of the run does steer one thing: while no
candidate reaches it, ``identify`` searches again. A threshold applied later that is lower
than the run's gives the decisions that a run at it would have given.)

Summary (``identify_summary.json``, ``identify_report.md``, ``confusion.png``): the confusion
matrix (rows: truth, columns: answer, each with a ``none``), top-1 identification on scenes
with a library garment, the rejection rate there, false acceptance on empty and on
other-things-only scenes, confusions within look-alike pairs, pose errors of correctly
identified garments next to those of the true model's search on every garment scene (that is
``locate``'s result on the scene), and times.
"""

from __future__ import annotations

import csv
import json
import math
import os
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from photomodel._files import write_atomic, write_atomic_with
from photomodel.errors import InputError
from photomodel.experiments._records import append_csv_rows, whole_lines
from photomodel.experiments._run import (
    config_changes,
    pool_stream,
    read_json,
    run_directory,
    run_metadata,
    write_json,
)
from photomodel.experiments._trials import ExperimentConfig, _model
from photomodel.geometry import in_plane_angle_rad, rotation_angle_deg

__all__ = [
    "IDENTIFY_COLUMNS",
    "IdentifyExperimentConfig",
    "IdentifyTrial",
    "plan_identify_trials",
    "read_identify_records",
    "run_identify_experiment",
    "run_identify_trial",
    "summarise_identify",
    "calibrate_from_records",
    "write_identify_report",
]

NONE = "none"
SUCCESS_POSITION_MM = 10.0
SUCCESS_ROTATION_DEG = 5.0

IDENTIFY_COLUMNS: tuple[str, ...] = (
    "trial_id", "truth", "condition", "index", "best_model", "best_score", "runner_up",
    "runner_up_score", "searched", "true_searched", "true_score", "true_err_pos_mm",
    "true_err_rot_deg", "err_pos_mm", "err_rot_deg", "err_x_mm", "err_y_mm", "err_z_mm",
    "err_theta_deg", "visible_fraction", "seconds", "scores",
)
"""Columns of ``identify.csv``. ``err_*`` are the best model's pose errors against the truth
(NaN without a target); ``true_*`` the true model's own search (when it was searched);
``scores`` a JSON object of the listed candidates' screening evidence and score."""


@dataclass(frozen=True)
class IdentifyExperimentConfig:
    """Settings of an identification experiment.

    Parameters
    ----------
    library : tuple of str
        Catalogue garments whose models form the library.
    garments : tuple of str
        Garments laid on the table (default: the library's).
    conditions : tuple of str
        Conditions of the scenes with a garment (``+``-joined presets).
    trials : int
        Scenes per garment and condition.
    negatives : tuple of str
        Conditions without a library garment (``empty``: the table alone, ``no-target``:
        other garments and objects only).
    negative_trials : int
        Scenes per negative condition.
    seed : int
    max_candidates : int
        Models searched per scene (:class:`~photomodel.identify.IdentifyConfig`).
    min_score : float or None
        Threshold applied in the summary (None: the stored, calibrated one).
    """

    library: tuple[str, ...]
    garments: tuple[str, ...] = ()
    conditions: tuple[str, ...] = ("paper",)
    trials: int = 1
    negatives: tuple[str, ...] = ("empty", "no-target")
    negative_trials: int = 10
    seed: int = 0
    max_candidates: int = 3
    min_score: float | None = None

    def __post_init__(self) -> None:
        if not self.library:
            raise ValueError("library: expected at least one garment")
        if self.trials < 0 or self.negative_trials < 0:
            raise ValueError("trials and negative_trials must be >= 0")

    @property
    def placed(self) -> tuple[str, ...]:
        """Garments laid on the table."""
        return self.garments or self.library

    def to_json_dict(self) -> dict[str, Any]:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.__dict__.items()}


@dataclass(frozen=True, order=True)
class IdentifyTrial:
    """One scene: ``garment`` (None: no library garment) under ``condition``, scene ``index``."""

    trial_id: str
    garment: str | None
    condition: str
    index: int


def plan_identify_trials(config: IdentifyExperimentConfig) -> list[IdentifyTrial]:
    """Every trial, in a fixed order (ids as ``photomodel simulate`` names the scenes)."""
    out = [IdentifyTrial(f"{c}_{g}_{k:04d}", g, c, k)
           for c in config.conditions for g in config.placed for k in range(config.trials)]
    out += [IdentifyTrial(f"{c}_{k:04d}", None, c, k)
            for c in config.negatives for k in range(config.negative_trials)]
    return out


@lru_cache(maxsize=4)
def _rig(conditions: tuple[str, ...]) -> Any:
    from photomodel.sim import hand_stereo_rig, parse_conditions

    lenses = {parse_conditions(c).lens for c in conditions}
    if len(lenses) != 1:
        raise ValueError("conditions ask for different lenses; run them as separate experiments")
    return hand_stereo_rig(lens=lenses.pop())



def _wrap_deg(angle: float) -> float:
    return float(-((-angle + 180.0) % 360.0 - 180.0))


@lru_cache(maxsize=2)
def _identifier(library: tuple[str, ...], seed: int, conditions: tuple[str, ...],
                min_score: float, max_candidates: int) -> Any:
    """An Identifier of the library's station models, kept for the trials of a process (a
    catalogue's models are built once, prepared when they are candidates)."""
    from photomodel.identify import Identifier, IdentifyConfig

    base = ExperimentConfig(seed=seed)
    models = [_model(base, name) for name in library]
    return Identifier(models, _rig(conditions), config=IdentifyConfig(min_score=min_score,
                                                         max_candidates=max_candidates),
                      prepared_models=min(len(models), 32))


def run_identify_trial(config: IdentifyExperimentConfig, trial: IdentifyTrial) -> dict[str, Any]:
    """Simulate the trial's scene, identify, and return its record (``IDENTIFY_COLUMNS``)."""
    from photomodel.sim import catalogue_garment, parse_conditions, scene_rng, simulate_scene

    rig = _rig(tuple(config.conditions) + tuple(config.negatives))
    target = None if trial.garment is None else catalogue_garment(trial.garment)
    shot = simulate_scene(target, rig, parse_conditions(trial.condition),
                          scene_rng(config.seed, trial.condition, trial.garment or "",
                                    trial.index))
    min_score = config.min_score
    if min_score is None:
        from photomodel.locate import load_threshold

        min_score = load_threshold().min_score
    identifier = _identifier(tuple(config.library), config.seed,
                             tuple(config.conditions) + tuple(config.negatives),
                             float(min_score), config.max_candidates)
    result = identifier(shot.right_bgr, shot.left_bgr,
                        rng=scene_rng(config.seed, "identify", trial.trial_id))
    nan = float("nan")
    row: dict[str, Any] = {
        "trial_id": trial.trial_id, "truth": trial.garment or NONE,
        "condition": trial.condition, "index": trial.index,
        "best_model": result.best.model if result.best is not None else NONE,
        "best_score": result.score,
        "runner_up": result.runner_up.model if result.runner_up is not None else NONE,
        "runner_up_score": (result.runner_up.score if result.runner_up is not None else 0.0),
        "searched": sum(c.result is not None for c in result.candidates),
        "true_searched": 0, "true_score": nan, "true_err_pos_mm": nan, "true_err_rot_deg": nan,
        "err_pos_mm": nan, "err_rot_deg": nan, "err_x_mm": nan, "err_y_mm": nan,
        "err_z_mm": nan, "err_theta_deg": nan,
        "visible_fraction": (shot.info["visible_fraction"] or [nan])[0],
        "seconds": result.seconds,
        "scores": json.dumps({c.model: [round(c.evidence, 4),
                                        None if c.score is None else round(c.score, 5),
                                        None if c.result is None
                                        else round(c.result.edge_evidence, 5)]
                              for c in result.candidates}, separators=(",", ":")),
    }
    T_true = shot.T_cam1_model
    if T_true is not None:
        true = next((c for c in result.candidates if c.model == trial.garment), None)
        if true is not None and true.result is not None:
            T = true.result.T_cam1_model
            row.update(true_searched=1, true_score=true.result.score,
                       true_err_pos_mm=float(np.linalg.norm(T[:3, 3] - T_true[:3, 3])),
                       true_err_rot_deg=rotation_angle_deg(T[:3, :3], T_true[:3, :3]))
        if result.best is not None:
            T = result.best.T_cam1_model
            err = T[:3, 3] - T_true[:3, 3]
            th = np.degrees(in_plane_angle_rad(T[:3, :3]) - in_plane_angle_rad(T_true[:3, :3]))
            row.update(err_pos_mm=float(np.linalg.norm(err)),
                       err_rot_deg=rotation_angle_deg(T[:3, :3], T_true[:3, :3]),
                       err_x_mm=float(err[0]), err_y_mm=float(err[1]), err_z_mm=float(err[2]),
                       err_theta_deg=_wrap_deg(float(th)))
    return row


# --- records ----------------------------------------------------------------------------------


def _append(path: Path, row: dict[str, Any]) -> None:
    append_csv_rows(path, IDENTIFY_COLUMNS, [{k: (repr(float(v)) if isinstance(v, float) else v)
                                              for k, v in row.items()}])


def read_identify_records(path: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The rows of ``identify.csv`` with numbers parsed (torn rows dropped).

    Raises
    ------
    InputError
        Missing or not an identification records file.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(p, "identification records not found")
    try:
        with whole_lines(p) as f:
            reader = csv.DictReader(f)
            if reader.fieldnames is None:
                return []
            if list(reader.fieldnames) != list(IDENTIFY_COLUMNS):
                raise InputError(p, "not an identification records file")
            rows = [r for r in reader if None not in r and None not in r.values()
                    and r["scores"].endswith("}")]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise InputError(p, f"cannot read records: {exc}") from None
    out, seen = [], set()
    for r in rows:
        if r["trial_id"] in seen:   # recorded twice (by runs before the run lock): the first
            continue
        seen.add(r["trial_id"])
        d: dict[str, Any] = dict(r)
        for k in ("index", "searched", "true_searched"):
            d[k] = int(r[k])
        for k in IDENTIFY_COLUMNS:
            if k not in d or isinstance(d[k], int) or k in (
                    "trial_id", "truth", "condition", "best_model", "runner_up", "scores"):
                continue
            d[k] = float(r[k])
        d["scores"] = json.loads(r["scores"])
        out.append(d)
    return out


# --- running -----------------------------------------------------------------------------------


def _stream(config: IdentifyExperimentConfig, trials: list[IdentifyTrial],
            workers: int) -> Iterator[dict[str, Any]]:
    if workers <= 1 or len(trials) <= 1:
        for t in trials:
            yield run_identify_trial(config, t)
        return
    yield from pool_stream(run_identify_trial, config, trials, workers)


def run_identify_experiment(
    out: str | os.PathLike[str],
    config: IdentifyExperimentConfig,
    *,
    workers: int | None = None,
    progress: Callable[[int, int, str], None] | None = None,
) -> dict[str, Any]:
    """Run (or resume) the experiment into ``out`` and summarise it.

    Writes ``identify_config.json`` (refuses other settings in a directory started with
    different ones), ``identify.csv`` (one row per trial, appended), then
    :func:`write_identify_report`.

    Returns
    -------
    dict
        The summary (:func:`summarise_identify`) with the run's metadata.
    """
    out = Path(out)
    with run_directory(out, ("identify_config.json",)):
        return _run_identify(out, config, workers, progress)


def _run_identify(out: Path, config: IdentifyExperimentConfig, workers: int | None,
                  progress: Callable[[int, int, str], None] | None) -> dict[str, Any]:
    cfg_path = out / "identify_config.json"
    wanted = config.to_json_dict()
    diff = config_changes(cfg_path, wanted, ignore=("min_score",))
    if diff:
        raise InputError(out, "holds an identification experiment with other settings "
                              f"({', '.join(diff)}); choose another --out")
    write_json(cfg_path, wanted)
    records = out / "identify.csv"
    trials = plan_identify_trials(config)
    if not trials:
        raise InputError(out, "the experiment has no trials")
    done = ({r["trial_id"] for r in read_identify_records(records)} if records.exists()
            else set())
    pending = [t for t in trials if t.trial_id not in done]
    workers = max(1, int(workers or os.cpu_count() or 1))
    t0 = time.perf_counter()
    n_done = len(trials) - len(pending)
    for row in _stream(config, pending, min(workers, max(1, len(pending)))):
        _append(records, row)
        n_done += 1
        if progress is not None:
            progress(n_done, len(trials), str(row["trial_id"]))
    wall = time.perf_counter() - t0
    if pending:
        _record_run(out, len(pending), wall)
    summary = write_identify_report(out, config, wall_seconds=wall)
    return summary


RUNS_FILE = "identify_runs.json"
"""Which commit ran which records of a run directory: ``{"runs": [{"commit", "trials",
"wall_seconds"}, ...]}``, one entry per command that added records."""


def _record_run(out: Path, trials: int, wall_seconds: float) -> None:
    path = out / RUNS_FILE
    runs = _read_runs(out) or []
    runs.append({"commit": run_metadata()["commit"], "trials": trials,
                 "wall_seconds": wall_seconds})
    write_json(path, {"runs": runs})


def _read_runs(out: Path) -> list[dict[str, Any]] | None:
    path = out / RUNS_FILE
    if not path.exists():
        return None
    runs = read_json(path)
    if not isinstance(runs, dict) or not isinstance(runs.get("runs"), list):
        raise InputError(path, "expected {\"runs\": [...]}")
    return list(runs["runs"])


# --- summary -----------------------------------------------------------------------------------


def _twin_pairs(library: Sequence[str]) -> list[tuple[str, str]]:
    from photomodel.sim import SIMILAR

    return [(name.split("-", 1)[0], name) for name in SIMILAR
            if name in library and name.split("-", 1)[0] in library]


def _stats(values: list[float]) -> dict[str, float | None]:
    a = np.asarray([v for v in values if math.isfinite(v)], dtype=np.float64)
    if len(a) == 0:
        return {"n": 0, "mean": None, "std": None, "median": None}
    return {"n": int(len(a)), "mean": float(a.mean()),
            "std": float(a.std(ddof=1)) if len(a) > 1 else 0.0, "median": float(np.median(a))}


def summarise_identify(rows: list[dict[str, Any]], library: Sequence[str],
                       min_score: float) -> dict[str, Any]:
    """Decisions at ``min_score`` and their statistics (see the module docstring)."""
    labels = [*library, NONE]
    index = {name: i for i, name in enumerate(labels)}
    matrix = np.zeros((len(labels), len(labels)), dtype=np.int64)
    answers = []
    for r in rows:
        answer = r["best_model"] if r["best_score"] >= min_score else NONE
        answers.append(answer)
        truth = r["truth"] if r["truth"] in index else NONE
        matrix[index[truth], index.get(answer, index[NONE])] += 1
    pos = [(r, a) for r, a in zip(rows, answers, strict=True) if r["truth"] != NONE]
    neg = [(r, a) for r, a in zip(rows, answers, strict=True) if r["truth"] == NONE]

    def rate(pairs: list[tuple[dict[str, Any], str]], ok: Callable[[dict[str, Any], str], bool]
             ) -> float | None:
        return None if not pairs else float(np.mean([ok(r, a) for r, a in pairs]))

    per_condition: dict[str, dict[str, Any]] = {}
    for cond in dict.fromkeys(r["condition"] for r in rows):
        p = [(r, a) for r, a in pos if r["condition"] == cond]
        n = [(r, a) for r, a in neg if r["condition"] == cond]
        per_condition[cond] = {
            "scenes": len(p) + len(n),
            "top1": rate(p, lambda r, a: a == r["truth"]),
            "rejected": rate(p, lambda r, a: a == NONE),
            "false_accept": rate(n, lambda r, a: a != NONE),
            "true_model_searched": rate(p, lambda r, a: bool(r["true_searched"])),
            "median_seconds": float(np.median([r["seconds"] for r, _ in p + n])),
        }
    correct = [r for r, a in pos if a == r["truth"]]

    def success(r: dict[str, Any], pos_key: str, rot_key: str) -> bool:
        return r[pos_key] < SUCCESS_POSITION_MM and r[rot_key] < SUCCESS_ROTATION_DEG

    searched = [r for r, _ in pos if r["true_searched"]]
    pairs = []
    for a, b in _twin_pairs(library):
        scenes = [(r, ans) for r, ans in pos if r["truth"] in (a, b)]
        confused = sum(1 for r, ans in scenes if ans == (b if r["truth"] == a else a))
        pairs.append({"pair": [a, b], "scenes": len(scenes), "confused": confused,
                      "confusion_rate": None if not scenes else confused / len(scenes)})
    return {
        "min_score": float(min_score),
        "labels": labels,
        "confusion": matrix.tolist(),
        "garment_scenes": len(pos),
        "negative_scenes": len(neg),
        "top1": rate(pos, lambda r, a: a == r["truth"]),
        "rejection_rate": rate(pos, lambda r, a: a == NONE),
        "wrong_garment_rate": rate(pos, lambda r, a: a not in (NONE, r["truth"])),
        "false_accept": rate(neg, lambda r, a: a != NONE),
        "per_condition": per_condition,
        "similar_pairs": pairs,
        "pose": {
            "identified": {"n": len(correct),
                           "success": (None if not correct else float(np.mean(
                               [success(r, "err_pos_mm", "err_rot_deg") for r in correct]))),
                           **{k: _stats([r[k] for r in correct if success(
                               r, "err_pos_mm", "err_rot_deg")])
                              for k in ("err_x_mm", "err_y_mm", "err_z_mm", "err_theta_deg")}},
            "true_model_search": {"n": len(searched),
                                  "success": (None if not searched else float(np.mean(
                                      [success(r, "true_err_pos_mm", "true_err_rot_deg")
                                       for r in searched])))},
        },
        "seconds": _stats([r["seconds"] for r in rows]),
        "searched_per_scene": _stats([float(r["searched"]) for r in rows]),
    }


def _fmt(x: float | None, pct: bool = True) -> str:
    if x is None:
        return "–"
    return f"{100 * x:.1f} %" if pct else f"{x:.3g}"


def write_identify_report(out: str | os.PathLike[str],
                          config: IdentifyExperimentConfig | None = None, *,
                          min_score: float | None = None,
                          wall_seconds: float | None = None) -> dict[str, Any]:
    """Summarise ``out/identify.csv``: ``identify_summary.json``, ``identify_report.md`` and
    ``confusion.png``; returns the summary.

    ``min_score`` (default: the config's, else the stored threshold) decides each scene.
    """
    from photomodel.locate import load_threshold

    out = Path(out)
    if config is None:
        path = out / "identify_config.json"
        try:
            data = json.loads(path.read_text())
        except FileNotFoundError:
            raise InputError(path, "not found (is this an identification run?)") from None
        for k in ("library", "garments", "conditions", "negatives"):
            data[k] = tuple(data.get(k) or ())
        config = IdentifyExperimentConfig(**data)
    given = min_score if min_score is not None else config.min_score
    if given is None:
        threshold = load_threshold()
        t, source = threshold.min_score, "stored, " + str(threshold.metadata.get("source", ""))
    else:
        t, source = given, "given"
    rows = read_identify_records(out / "identify.csv")
    summary = summarise_identify(rows, config.library, t)
    summary["settings"] = config.to_json_dict()
    summary["threshold_source"] = source
    summary.update(run_metadata())
    if wall_seconds is not None:
        summary["wall_seconds_this_run"] = wall_seconds
    write_json(out / "identify_summary.json", summary)
    _confusion_figure(summary, out / "confusion.png")
    lines = [
        "# Identification experiment", "",
        f"Library: {', '.join(config.library)}; threshold min_score = {t:.3f} "
        f"({summary['threshold_source']}).", "",
        "| | value |", "|---|---:|",
        f"| scenes with a library garment | {summary['garment_scenes']} |",
        f"| top-1 identification | {_fmt(summary['top1'])} |",
        f"| rejected (answered none) | {_fmt(summary['rejection_rate'])} |",
        f"| wrong garment named | {_fmt(summary['wrong_garment_rate'])} |",
        f"| scenes without one | {summary['negative_scenes']} |",
        f"| false acceptance | {_fmt(summary['false_accept'])} |",
        f"| median seconds per scene | {_fmt(summary['seconds']['median'], False)} |", "",
        "| condition | scenes | top-1 | rejected | false acceptance | true model searched |"
        " median s |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for cond, s in summary["per_condition"].items():
        lines.append(f"| {cond} | {s['scenes']} | {_fmt(s['top1'])} | {_fmt(s['rejected'])} | "
                     f"{_fmt(s['false_accept'])} | {_fmt(s['true_model_searched'])} | "
                     f"{s['median_seconds']:.2f} |")
    if summary["similar_pairs"]:
        lines += ["", "| look-alike pair | scenes | confused |", "|---|---:|---:|"]
        for p in summary["similar_pairs"]:
            lines.append(f"| {' / '.join(p['pair'])} | {p['scenes']} | {p['confused']} |")
    pose = summary["pose"]
    lines += ["", f"Pose of correctly identified garments: {pose['identified']['n']} scenes, "
                  f"success (< {SUCCESS_POSITION_MM:g} mm, < {SUCCESS_ROTATION_DEG:g} deg) "
                  f"{_fmt(pose['identified']['success'])}; the true model's own search "
                  f"(= locate) on all {pose['true_model_search']['n']} scenes where it ran: "
                  f"{_fmt(pose['true_model_search']['success'])}.", "",
              "![confusion matrix](confusion.png)", ""]
    write_atomic(out / "identify_report.md", "\n".join(lines).encode("utf-8"))
    return summary


def _confusion_figure(summary: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = summary["labels"]
    m = np.asarray(summary["confusion"], dtype=np.float64)
    rows = m.sum(axis=1, keepdims=True)
    share = np.divide(m, rows, out=np.zeros_like(m), where=rows > 0)
    n = len(labels)
    fig, ax = plt.subplots(figsize=(1.0 + 0.55 * n, 0.8 + 0.5 * n), dpi=110)
    ax.imshow(share, cmap="Blues", vmin=0, vmax=1)
    for i in range(n):
        for j in range(n):
            if m[i, j]:
                ax.text(j, i, str(int(m[i, j])), ha="center", va="center", fontsize=8,
                        color="white" if share[i, j] > 0.6 else "black")
    ax.set_xticks(range(n), labels, rotation=60, ha="right", fontsize=8)
    ax.set_yticks(range(n), labels, fontsize=8)
    ax.set_xlabel("identified as")
    ax.set_ylabel("on the table")
    ax.set_title(f"identify: top-1 {_fmt(summary['top1'])}, false acceptance "
                 f"{_fmt(summary['false_accept'])}", fontsize=9)
    fig.tight_layout()
    try:
        write_atomic_with(path, fig.savefig)
    finally:
        plt.close(fig)


def calibrate_from_records(out: str | os.PathLike[str], *, max_false_accept: float = 0.01,
                           command: str = "") -> Any:
    """Calibrate ``identify``'s threshold on the records of the run directory ``out``.

    Positives: the true model's score in every garment scene (0 when the colour screen dropped
    it: no threshold can save that scene). Negatives: the best score of any model in every
    scene without a library garment. See :func:`photomodel.locate.calibrate_threshold`.

    Returns
    -------
    photomodel.locate.Threshold
        With metadata: the command, settings, counts, rates, score quantiles, commit.
    """
    from photomodel.locate import Threshold, calibrate_threshold

    out = Path(out)
    runs = _read_runs(out)
    now = run_metadata()["commit"]
    if runs is None:
        raise InputError(out / RUNS_FILE, "not found: no record of which code made the scores; "
                                          "calibrate on a new --out")
    stale = sorted({str(r.get("commit")) for r in runs} - {now})
    if stale:
        raise InputError(out, f"holds scores made at commit {', '.join(c[:10] for c in stale)}, "
                              f"not at {str(now)[:10]}: they may not be the scores of this code; "
                              "calibrate on a new --out")
    rows = read_identify_records(out / "identify.csv")
    positives = [r["true_score"] if r["true_searched"] else 0.0 for r in rows
                 if r["truth"] != NONE]
    negatives = [r["best_score"] for r in rows if r["truth"] == NONE]
    if not positives or not negatives:
        raise InputError(out / "identify.csv", "calibration needs scenes with and without a "
                                               "library garment")
    t, stats = calibrate_threshold(positives, negatives, max_false_accept=max_false_accept)
    try:
        settings = json.loads((out / "identify_config.json").read_text())
    except (OSError, ValueError):
        settings = {}
    meta = run_metadata()
    return Threshold(t, {"source": f"calibrated on {len(positives)} + {len(negatives)} "
                                   f"simulated scenes", "command": command,
                         "settings": settings, **stats, "commit": meta["commit"],
                         "versions": meta["versions"]})
