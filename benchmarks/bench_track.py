"""Benchmark: the pose tracker (``pm.Tracker``) on simulated stereo sequences, against a full
locate of every frame.

Data: per garment (``--garments``, default the paper's ``No.6`` and ``No.3``), per sequence
kind (``approach``, ``conveyor``, ``occluder``, ``lost``: :data:`photomodel.sim.SEQUENCE_KINDS`)
and frame rate (30 and 60 fps), one simulated sequence of ``--seconds`` (2 s) with per-frame
truth (:func:`photomodel.sim.simulate_sequence`, seed ``--seed``), rendered into memory before
it is timed; the garment's model is :func:`photomodel.sim.station_model` of the same seed.

Per sequence, one new ``Tracker(model, rig)`` is called on every frame in order
(``tracker(right, left, t_s=frame.t_s, rng=...)``); one ``Locator(model, rig)`` per garment
(the baseline: a full search of the pair) is called on every ``--every``-th frame and on every
frame of the still stretch (below), before or after the tracker in turns (so that the
machine's state falls on both alike). numba runs on one thread (run as a script,
``NUMBA_NUM_THREADS=1`` is set before numba is imported, unless the environment sets it), and
both are warmed up, untimed,
before the first sequence of a garment.

Reported per sequence (a row), from the per-frame list that the row keeps too:

speed       time of ``track``-mode frames (median, p90, p99, max; also of those with no
            locate between them and the tracker's previous call), of the locate calls on
            every ``--every``-th frame (median, p99), the ratio of the medians (full /
            track), the share of frames tracked without a detection (``mode == "track"``
            among the frames after the first whose truth is visible >= 0.5), the
            re-detection time (``detect``-mode frames after frame 0);
accuracy    success = position error <= 10 mm and rotation angle error <= 5 deg, as the
            share of frames whose truth is visible >= 0.5 (a frame without a pose fails);
            error median, p95, max over found frames whose truth is visible >= 0.5; the
            paper's Table 1 form (mean and sd of the x, y, z errors in camera 1 and of the
            in-plane angle error) over successful frames;
jitter      on the still stretch (the frames from frame 0 on while the truth pose equals
            frame 0's within 0.01 mm and its visible share within 0.01: the garment lies
            still, the hand stands and nothing covers it; ``lost`` and ``occluder`` only):
            the sd of the tracked positions (sqrt of the sum of the three axes' variances,
            and per axis) against the locate's on the same frames;
events      ``lost`` latency: frames from the first whose truth is absent or visible < 0.1
            until the tracker reports ``lost`` (``lost`` kind); phantom frames: truth absent,
            tracker found; re-found latency: frames from the first whose truth is visible
            >= 0.5 after an absence (absent or < 0.1) until the tracker finds the garment.

``summary`` pools the rows of every garment except those of ``--apart`` (default ``No.1``,
which a full locate does not find on the conveyor belt at all, a known limitation), which get
a summary each in ``summary_apart``; each figure beside its target (:data:`TARGETS`) and
whether it is met.

Run: ``.venv/bin/python benchmarks/bench_track.py`` (16 sequences, 1,440 frames: about
6 minutes on 2 cores, of which rendering about 3: 0.13 s a frame). Smoke: ``--garments No.6 --kinds
lost --fps 30 --seconds 0.5 --out build/bench-smoke/track.json``.
"""

from __future__ import annotations

import os

if __name__ == "__main__":     # run as the benchmark; imported (its tests) it changes nothing
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")   # before numba is imported

import argparse  # noqa: E402
import hashlib  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Sequence  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from _meta import metadata  # noqa: E402

KINDS = ("approach", "conveyor", "occluder", "lost")
STILL_KINDS = ("lost", "occluder")
TARGETS: dict[str, float] = {
    "track_median_ms_max": 3, "track_p99_ms_max": 8, "speedup_min": 10, "success_min": 0.99,
    "lost_latency_max": 2, "refound_latency_max": 2, "phantom_max": 0,
    "jitter_over_locate_max": 1.0}
SUCCESS_MM = 10.0
SUCCESS_DEG = 5.0
VISIBLE_MIN = 0.5      # frames that count for success and the tracked share
ABSENT_BELOW = 0.1     # truth visible below this (or no truth): the garment is gone
STILL_MM = 0.01
FIGURE_TARGETS = {"track_median_ms": "track_median_ms_max", "track_p99_ms": "track_p99_ms_max",
                  "speedup": "speedup_min", "success": "success_min",
                  "lost_latency": "lost_latency_max", "refound_latency": "refound_latency_max",
                  "phantom": "phantom_max", "jitter_over_locate": "jitter_over_locate_max"}
"""Each summary figure's target (a key of :data:`TARGETS`)."""
REPO = Path(__file__).resolve().parents[1]


# ----------------------------------------------------------------------------- figures

def _num(x: float | None) -> float | None:
    """A JSON number (None for NaN or None)."""
    return None if x is None or not np.isfinite(x) else float(x)


def stats(values: Sequence[float], quantiles: Sequence[float] = (0.5, 0.9, 0.99),
          scale: float = 1.0) -> dict[str, Any]:
    """``n``, the quantiles (``median``, ``p90``, ``p99``, ...) and ``max`` of ``values``
    times ``scale`` (None when there are none)."""
    a = scale * np.asarray(values, dtype=np.float64)
    out: dict[str, Any] = {"n": int(a.size)}
    for q in quantiles:
        key = "median" if q == 0.5 else f"p{round(100 * q)}"
        out[key] = _num(float(np.quantile(a, q))) if a.size else None
    out["max"] = _num(float(a.max())) if a.size else None
    return out


def stats_ms(seconds: Sequence[float], quantiles: Sequence[float] = (0.5, 0.9, 0.99)
             ) -> dict[str, Any]:
    """:func:`stats` of times in s, in ms."""
    return stats(seconds, quantiles, 1e3)


def errors(T_est: np.ndarray, T_true: np.ndarray) -> dict[str, float]:
    """Errors of ``T_est`` against ``T_true`` (4x4, camera 1): position (mm) and its x, y, z
    parts (estimate less truth), rotation angle (deg) and in-plane angle error (deg, wrapped
    to [-180, 180))."""
    from photomodel.geometry import in_plane_angle_rad

    d = T_est[:3, 3] - T_true[:3, 3]
    c = (np.trace(T_est[:3, :3].T @ T_true[:3, :3]) - 1.0) / 2.0
    theta = np.degrees(in_plane_angle_rad(T_est[:3, :3]) - in_plane_angle_rad(T_true[:3, :3]))
    return {"pos_mm": float(np.linalg.norm(d)), "x": float(d[0]), "y": float(d[1]),
            "z": float(d[2]), "rot_deg": float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))),
            "theta_deg": float((theta + 180.0) % 360.0 - 180.0)}


def position_sd(positions: Sequence[Sequence[float]]) -> dict[str, Any]:
    """Spread of positions (N, 3), mm: ``sd`` = sqrt of the sum of the axes' variances (the
    RMS distance from their mean), and ``sd_xyz`` per axis; None with fewer than 2."""
    p = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    if len(p) < 2:
        return {"n": len(p), "sd": None, "sd_xyz": None}
    var = p.var(axis=0, ddof=1)
    return {"n": len(p), "sd": float(np.sqrt(var.sum())), "sd_xyz": np.sqrt(var).tolist()}


def still_frames(truth: Sequence[tuple[np.ndarray | None, float]]) -> list[int]:
    """The still stretch: frames from 0 on while the truth pose equals frame 0's within
    :data:`STILL_MM` (position, and the rotation matrix's entries times 100 mm) and the
    visible share stays within 0.01 of frame 0's."""
    if not truth or truth[0][0] is None:
        return []
    T0, v0 = truth[0]
    out = []
    for k, (T, v) in enumerate(truth):
        if (T is None or np.abs(T[:3, 3] - T0[:3, 3]).max() > STILL_MM
                or 100.0 * np.abs(T[:3, :3] - T0[:3, :3]).max() > STILL_MM
                or abs(v - v0) > 0.01):
            break
        out.append(k)
    return out


def event_latencies(frames: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """``lost``: from the first frame whose truth is gone (absent or visible <
    :data:`ABSENT_BELOW`) to the first frame from there on that the tracker reports lost;
    ``refound``: from the first frame whose truth is visible >= :data:`VISIBLE_MIN` after
    that to the first frame from there on that it finds the garment (and whether that pose
    succeeds), and to the first frame whose pose succeeds (``refound_correct``). Latencies
    in frames; None where the event does not happen, ``never`` where
    the tracker does not answer it before the sequence ends."""
    gone = next((f["frame"] for f in frames
                 if not f["truth_present"] or f["truth_visible"] < ABSENT_BELOW), None)
    out: dict[str, Any] = {"gone_frame": gone, "lost_frame": None, "lost_latency": None,
                           "lost_never": False, "back_frame": None, "refound_frame": None,
                           "refound_latency": None, "refound_never": False,
                           "refound_success": None, "refound_correct_frame": None,
                           "refound_correct_latency": None}
    if gone is None:
        return out
    lost = next((f["frame"] for f in frames[gone:] if f["mode"] == "lost"), None)
    out.update(lost_frame=lost, lost_latency=None if lost is None else lost - gone,
               lost_never=lost is None)
    back = next((f["frame"] for f in frames[gone:]
                 if f["truth_present"] and f["truth_visible"] >= VISIBLE_MIN), None)
    if back is not None:
        found = next((f for f in frames[back:] if f["found"]), None)
        out.update(back_frame=back, refound_never=found is None,
                   refound_frame=None if found is None else found["frame"],
                   refound_latency=None if found is None else found["frame"] - back,
                   refound_success=None if found is None else found["success"])
        correct = next((f["frame"] for f in frames[back:] if f["success"]), None)
        out.update(refound_correct_frame=correct,
                   refound_correct_latency=None if correct is None else correct - back)
    return out


def summarise_sequence(frames: list[dict[str, Any]], still: list[int]) -> dict[str, Any]:
    """A row's figures from its per-frame list (see the module's docstring)."""
    counted = [f for f in frames if f["truth_present"] and f["truth_visible"] >= VISIBLE_MIN]
    found = [f for f in counted if f["found"]]
    ok = [f for f in counted if f["success"]]
    track_s = [f["seconds"] for f in frames if f["mode"] == "track"]
    quiet_s = [f["seconds"] for f in frames if f["mode"] == "track" and not f["after_locate"]]
    locate_s = [f["locate"]["seconds"] for f in frames
                if f["locate"] is not None and f["locate"]["timed"]]
    redetect_s = [f["seconds"] for f in frames[1:] if f["mode"] == "detect"]
    paired = [f["locate"]["seconds"] / f["seconds"] for f in frames
              if f["mode"] == "track" and f["locate"] is not None and f["locate"]["timed"]]
    after_first = [f for f in counted if f["frame"] > 0]
    track = stats_ms(track_s)
    locate = stats_ms(locate_s, (0.5, 0.99))
    table1 = ({k: {"mean": float(np.mean([f["err"][k] for f in ok])),
                   "sd": float(np.std([f["err"][k] for f in ok]))}
               for k in ("x", "y", "z", "theta_deg")} if ok else {})
    jitter = None
    if still:
        tracked = [frames[k] for k in still if frames[k]["mode"] == "track"]
        located = [frames[k] for k in still if frames[k]["locate"] is not None
                   and frames[k]["locate"]["found"]]
        t_sd = position_sd([f["position_mm"] for f in tracked])
        l_sd = position_sd([f["locate"]["position_mm"] for f in located])
        jitter = {"frames": still, "track": t_sd, "locate": l_sd,
                  "track_over_locate": (t_sd["sd"] / l_sd["sd"]
                                        if t_sd["sd"] is not None and l_sd["sd"] else None)}
    return {
        "frames": len(frames),
        "modes": {m: sum(f["mode"] == m for f in frames) for m in ("detect", "track", "lost")},
        "track_ms": track,
        "track_quiet_ms": stats_ms(quiet_s),
        "locate_ms": locate,
        "speedup": (locate["median"] / track["median"]
                    if locate["median"] is not None and track["median"] else None),
        "speedup_paired_median": float(np.median(paired)) if paired else None,
        "tracked_share": (float(np.mean([f["mode"] == "track" for f in after_first]))
                          if after_first else None),
        "redetect_ms": stats_ms(redetect_s, (0.5,)),
        "detect_first_ms": 1e3 * frames[0]["seconds"],
        "counted_frames": len(counted),
        "success": len(ok) / len(counted) if counted else None,
        "successes": len(ok),
        "pos_err_mm": stats([f["err"]["pos_mm"] for f in found], (0.5, 0.95)),
        "rot_err_deg": stats([f["err"]["rot_deg"] for f in found], (0.5, 0.95)),
        "table1": table1,
        "jitter": jitter,
        "phantom": sum(not f["truth_present"] and f["found"] for f in frames),
        "events": event_latencies(frames),
        "failed": [{k: f[k] for k in ("frame", "truth_visible", "mode", "note")}
                   | {"pos_mm": f["err"]["pos_mm"] if f["err"] else None,
                      "rot_deg": f["err"]["rot_deg"] if f["err"] else None}
                   for f in counted if not f["success"]],
    }


def summarise(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The overall figures of ``rows`` (pooled frames), each with its target and whether it
    is met."""
    frames = [f for r in rows for f in r["frames"]]
    figures = [r["figures"] for r in rows]
    track = stats_ms([f["seconds"] for f in frames if f["mode"] == "track"])
    quiet = stats_ms([f["seconds"] for f in frames
                      if f["mode"] == "track" and not f["after_locate"]])
    locate = stats_ms([f["locate"]["seconds"] for f in frames
                       if f["locate"] is not None and f["locate"]["timed"]], (0.5, 0.99))
    counted = sum(g["counted_frames"] for g in figures)
    success = sum(g["successes"] for g in figures) / counted if counted else None
    tracked = [f["mode"] == "track" for r in rows for f in r["frames"][1:]
               if f["truth_present"] and f["truth_visible"] >= VISIBLE_MIN]
    lost = [g["events"]["lost_latency"] for r, g in zip(rows, figures, strict=True)
            if r["kind"] == "lost"]
    refound = [g["events"]["refound_latency"] for g in figures
               if g["events"]["back_frame"] is not None]
    jitter = [g["jitter"]["track_over_locate"] for g in figures if g["jitter"] is not None]
    speedup = (locate["median"] / track["median"]
               if locate["median"] is not None and track["median"] else None)
    paired = [f["locate"]["seconds"] / f["seconds"] for f in frames
              if f["mode"] == "track" and f["locate"] is not None and f["locate"]["timed"]]
    phantom = sum(g["phantom"] for g in figures)

    def worst(values: list[int | None]) -> int | None:
        return None if not values or any(v is None for v in values) else max(values)

    def worst_ratio(values: list[float | None]) -> float | None:
        return None if not values or any(v is None for v in values) else max(values)

    lost_max, refound_max, jitter_max = worst(lost), worst(refound), worst_ratio(jitter)
    figures_out = {
        "track_median_ms": track["median"], "track_p99_ms": track["p99"],
        "speedup": speedup, "success": success, "lost_latency": lost_max,
        "refound_latency": refound_max, "phantom": phantom, "jitter_over_locate": jitter_max}
    met = {
        "track_median_ms_max": _le(track["median"], TARGETS["track_median_ms_max"]),
        "track_p99_ms_max": _le(track["p99"], TARGETS["track_p99_ms_max"]),
        "speedup_min": _le(TARGETS["speedup_min"], speedup),
        "success_min": _le(TARGETS["success_min"], success),
        "lost_latency_max": _le(lost_max, TARGETS["lost_latency_max"]),
        "refound_latency_max": _le(refound_max, TARGETS["refound_latency_max"]),
        "phantom_max": phantom <= TARGETS["phantom_max"],
        "jitter_over_locate_max": _le(jitter_max, TARGETS["jitter_over_locate_max"])}
    by = {f"{r['garment']} {r['kind']} {r['fps']:g}fps": r["figures"]["success"] for r in rows}
    return {
        "garments": sorted({r["garment"] for r in rows}), "sequences": len(rows),
        "frames": len(frames), "targets": TARGETS, "figures": figures_out, "met": met,
        "all_met": all(met.values()),
        "track_ms": track, "track_quiet_ms": quiet, "locate_ms": locate,
        "speedup_paired_median": float(np.median(paired)) if paired else None,
        "tracked_share": float(np.mean(tracked)) if tracked else None,
        "redetect_ms": stats_ms([f["seconds"] for r in rows for f in r["frames"][1:]
                                 if f["mode"] == "detect"], (0.5, 0.9)),
        "counted_frames": counted, "success_by_sequence": by,
        "lost_latencies": lost, "refound_latencies": refound,
        "refound_correct_latencies": [g["events"]["refound_correct_latency"] for g in figures
                                      if g["events"]["back_frame"] is not None],
        "jitter_over_locate": jitter,
        "failed": [{"garment": r["garment"], "kind": r["kind"], "fps": r["fps"], **f}
                   for r in rows for f in r["figures"]["failed"]],
    }


def _le(a: float | None, b: float | None) -> bool:
    return a is not None and b is not None and a <= b


# ----------------------------------------------------------------------------- running

def frame_rng(seed: int, *names: str | int) -> np.random.Generator:
    from photomodel.sim import scene_rng

    return scene_rng(seed, "bench-track", *names)


def warm_up(model: Any, rig: Any, locator: Any, frames: list[Any]) -> None:
    """Load every kernel: a locate and a tracker's first frames, untimed."""
    from photomodel.track import Tracker

    locator(frames[0].right_bgr, frames[0].left_bgr, rng=0)
    tracker = Tracker(model, rig)
    for f in frames[:4]:
        tracker(f.right_bgr, f.left_bgr, t_s=f.t_s, rng=0)


def run_sequence(model: Any, rig: Any, locator: Any, frames: list[Any], garment: str,
                 kind: str, fps: float, every: int, seed: int) -> dict[str, Any]:
    """One sequence through a new tracker, the locator on every ``every``-th frame and the
    still stretch; the per-frame list and the row's figures."""
    from photomodel.track import Tracker

    still = still_frames([(f.T_cam1_model, float(f.visible)) for f in frames]
                         ) if kind in STILL_KINDS else []
    tracker = Tracker(model, rig)
    rows: list[dict[str, Any]] = []
    turns = 0
    for f in frames:
        k = f.index
        timed = k % every == 0
        run_locate = timed or k in still
        order = ("locate", "track") if turns % 2 == 0 else ("track", "locate")
        if run_locate:
            turns += 1
        else:
            order = ("track",)
        res = loc = None
        loc_s = 0.0
        for what in order:
            if what == "locate":
                t0 = time.perf_counter()
                loc = locator(f.right_bgr, f.left_bgr, rng=frame_rng(seed, garment, kind,
                                                                      int(fps), k, "locate"))
                loc_s = time.perf_counter() - t0
            else:
                res = tracker(f.right_bgr, f.left_bgr, t_s=f.t_s,
                              rng=frame_rng(seed, garment, kind, int(fps), k, "track"))
        assert res is not None
        T_true = f.T_cam1_model
        err = (errors(res.T_cam1_model, T_true)
               if T_true is not None and res.found and res.mode != "lost" else None)
        row = {"frame": k, "t_s": float(f.t_s), "truth_present": T_true is not None,
               "truth_visible": float(f.visible), "mode": res.mode, "found": bool(res.found),
               "err": err, "angle_err_deg": None if err is None else err["rot_deg"],
               "success": err is not None and err["pos_mm"] <= SUCCESS_MM
               and err["rot_deg"] <= SUCCESS_DEG,
               "seconds": float(res.seconds), "score": _num(res.score),
               "evaluations": int(res.search.evaluations), "note": res.note,
               "position_mm": res.T_cam1_model[:3, 3].tolist() if res.found else None,
               "after_locate": bool(rows) and rows[-1]["locate_after"],
               "locate_after": order[-1] == "locate", "locate": None}
        if loc is not None:
            lerr = errors(loc.T_cam1_model, T_true) if T_true is not None and loc.found else None
            row["locate"] = {"seconds": loc_s, "timed": timed, "found": bool(loc.found),
                             "first": order[0] == "locate",
                             "pos_mm": None if lerr is None else lerr["pos_mm"],
                             "rot_deg": None if lerr is None else lerr["rot_deg"],
                             "position_mm": loc.T_cam1_model[:3, 3].tolist()}
        # a locate before the tracker's call also comes between it and its previous call
        row["after_locate"] = row["after_locate"] or order[0] == "locate"
        rows.append(row)
    for r in rows:
        del r["locate_after"]
    return {"garment": garment, "kind": kind, "fps": fps, "still_frames": still,
            "figures": summarise_sequence(rows, still), "frames": rows}


def tracker_source() -> dict[str, Any]:
    """What tracker is measured (call it when the run starts): a digest of
    ``src/photomodel/track/*.py`` (imported here) and the files of ``src/`` that differ from
    the commit."""
    import photomodel.track._tracker as module

    folder = Path(module.__file__).parent
    digest = hashlib.sha256()
    for path in sorted(folder.glob("*.py")):
        digest.update(path.name.encode() + b"\0" + path.read_bytes())
    try:
        dirty = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "src"],
                               capture_output=True, text=True, check=True,
                               timeout=10).stdout.split("\n")
        changed: list[str] | None = [line[3:] for line in dirty if line.strip()]
    except (OSError, subprocess.SubprocessError):
        changed = None
    return {"track_sha256": digest.hexdigest(), "src_changed": changed}


def threads() -> dict[str, Any]:
    import cv2
    import numba

    return {"NUMBA_NUM_THREADS": os.environ.get("NUMBA_NUM_THREADS"),
            "numba_threads": numba.get_num_threads(), "opencv_threads": cv2.getNumThreads()}


def print_row(row: dict[str, Any], render_s: float) -> None:
    g = row["figures"]
    t, lo = g["track_ms"], g["locate_ms"]
    ev = g["events"]

    def ms(x: float | None) -> str:
        return "-" if x is None else f"{x:.2f}"

    print(f"{row['garment']} {row['kind']} {row['fps']:g} fps: {g['frames']} frames "
          f"{g['modes']}; success {g['successes']}/{g['counted_frames']}; track ms median "
          f"{ms(t['median'])} p99 {ms(t['p99'])} max {ms(t['max'])}; locate ms median "
          f"{ms(lo['median'])}; speedup {ms(g['speedup'])}; lost latency "
          f"{ev['lost_latency']}, refound {ev['refound_latency']}, phantom {g['phantom']}"
          + (f"; jitter {ms(g['jitter']['track']['sd'])} vs {ms(g['jitter']['locate']['sd'])}"
             f" mm" if g["jitter"] else "")
          + f" (render {render_s:.0f} s)", file=sys.stderr, flush=True)


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--garments", default="No.6,No.3", help="comma-separated (default "
                   "No.6,No.3)")
    p.add_argument("--apart", default="No.1", help="garments summarised apart (default No.1)")
    p.add_argument("--kinds", default=",".join(KINDS))
    p.add_argument("--fps", default="30,60", help="frame rates (default 30,60)")
    p.add_argument("--seconds", type=float, default=2.0, help="length of a sequence (2 s)")
    p.add_argument("--every", type=int, default=3, help="locate every N-th frame (3)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "track.json")
    args = p.parse_args(argv)
    garments = [g for g in args.garments.split(",") if g]
    apart = {g for g in args.apart.split(",") if g}
    kinds = [k for k in args.kinds.split(",") if k]
    fps_list = [float(x) for x in args.fps.split(",") if x]
    if not garments or not kinds or not fps_list:
        p.error("--garments, --kinds and --fps need at least one value each")
    if bad := [k for k in kinds if k not in KINDS]:
        p.error(f"--kinds: expected some of {', '.join(KINDS)}, got {', '.join(bad)}")
    if args.every < 1:
        p.error("--every must be >= 1")

    from photomodel.locate import Locator
    from photomodel.sim import (
        SequenceSettings,
        hand_stereo_rig,
        simulate_sequence,
        station_model,
    )

    t_start = time.perf_counter()
    load_start = os.getloadavg()
    meta, source = metadata("track", args.seed), tracker_source()   # what is measured
    rig = hand_stereo_rig()
    rows: list[dict[str, Any]] = []
    render_total = 0.0
    for garment in garments:
        model = station_model(garment, args.seed)
        locator = Locator(model, rig)
        warm = False
        for kind in kinds:
            for fps in fps_list:
                t0 = time.perf_counter()
                frames = list(simulate_sequence(SequenceSettings(
                    kind=kind, fps=fps, seconds=args.seconds, garment=garment,
                    seed=args.seed)))
                render_s = time.perf_counter() - t0
                render_total += render_s
                if not warm:
                    warm_up(model, rig, locator, frames)
                    warm = True
                row = run_sequence(model, rig, locator, frames, garment, kind, fps,
                                   args.every, args.seed)
                row["render_seconds"] = render_s
                rows.append(row)
                print_row(row, render_s)
                del frames

    main_rows = [r for r in rows if r["garment"] not in apart]
    out = {**meta,
           "settings": {"garments": garments, "apart": sorted(apart & set(garments)),
                        "kinds": kinds, "fps": fps_list, "seconds": args.seconds,
                        "every": args.every, "success_mm": SUCCESS_MM,
                        "success_deg": SUCCESS_DEG, "visible_min": VISIBLE_MIN,
                        "absent_below": ABSENT_BELOW, "still_mm": STILL_MM,
                        "threads": threads()},
           "loadavg": {"start": load_start, "end": os.getloadavg()},
           "tracker": source,
           "summary": summarise(main_rows) if main_rows else None,
           "summary_apart": {g: summarise([r for r in rows if r["garment"] == g])
                             for g in garments if g in apart},
           "rows": rows,
           "render_seconds": render_total,
           "wall_seconds": time.perf_counter() - t_start}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_name(f".{args.out.name}.tmp")
    tmp.write_text(json.dumps(out, indent=1) + "\n")
    os.replace(tmp, args.out)
    for name, s in [("summary", out["summary"]), *out["summary_apart"].items()]:
        if s is None:
            continue
        print(f"{args.out} {name} ({', '.join(s['garments'])}):")
        for key, value in s["figures"].items():
            target = FIGURE_TARGETS[key]
            shown = "-" if value is None else f"{value:.4g}"
            print(f"  {key:20s} {shown:>10}  target {target} {TARGETS[target]:g}: "
                  f"{'met' if s['met'][target] else 'NOT met'}")
        print(f"  tracked share {s['tracked_share']:.3f}; success by sequence:")
        for seq, share in s["success_by_sequence"].items():
            print(f"    {seq:24s} {'-' if share is None else f'{share:.3f}'}")
    return out


if __name__ == "__main__":
    main()
