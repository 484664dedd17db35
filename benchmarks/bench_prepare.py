"""Benchmark: preparing catalogue models for a rig, against a baseline revision in the same run.

What an identification pays for a candidate model it meets for the first time, measured for
this working tree and a baseline revision (``--baseline``, default ``HEAD``: the uncommitted
edits against the last commit), each in its own subprocesses (``PYTHONPATH=<tree>/src``, a
git worktree for the baseline, as :mod:`bench_startup` makes it). Figures per tree:

``prepare``     ``pm.Locator(model, rig)`` (its :func:`~photomodel.locate.prepare_model` on a
                blank pair of the rig): wall seconds per model, and CPU seconds (all threads);
``cold``        ``locate_in_features(PreparedModel(model), features, rng=k)`` on a model never
                prepared (it prepares on the pair's own features), per scene;
``warm``        the same call again, the model prepared;
``memory_mb``   the arrays a prepared model keeps (samples, points, scan plans), per model.

And the results, compared between the trees: each scene's ``Locator(model, rig)(right, left,
rng=k)`` and its cold locate (pose, fitness, score, found: identical to the bit or not, the
largest position difference).

Data: the first ``--models`` articles of the simulated catalogue (``cat-00000``, ...), each
built from its simulated model photos as a station builds it (kept in ``--work`` between
runs), one scene each, the conditions in turn from the paper's, four lamps and clutter.

Interleaved: in each of ``--repeats`` rounds, one worker per tree (it loads the data, makes one
``Locator`` and locates once untimed, then times every model and scene), the order alternating
from round to round, so that the machine's load falls on both alike. Reported per figure:
median, p90, ratio of the medians (current / baseline), the median of the paired ratios and
a seeded bootstrap 90 % interval (:func:`bench_startup.compare`).

Run: ``.venv/bin/python benchmarks/bench_prepare.py`` (20 models, 5 rounds: about 2 minutes on
two cores once both trees' kernels are compiled; a new baseline worktree compiles them first,
1-2 minutes; the models are built once, about 0.5 s each). Smoke: ``--models 2 --repeats 1
--baseline WORKTREE`` (this tree against itself).
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import os
import pickle
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from _meta import metadata
from bench_startup import (
    REPO,
    WORKTREE,
    Tree,
    compare,
    ensure_worktree,
    remove_worktree,
    resolve_revision,
    round_order,
    tree_env,
)

CONDITIONS = ("paper", "dim", "bright", "warm-light", "cool-light", "distractors", "overlap",
              "gripper")
"""The scenes' conditions, in turn."""


# ----------------------------------------------------------------------------- data

def build_data(work: Path, count: int, seed: int) -> Path:
    """The model files of the first ``count`` catalogue articles in ``work/models`` (built when
    missing) and their scenes in ``work/scenes-<count>-<seed>.pkl``; the scenes' path."""
    from photomodel.model import build_photo_model, save_model
    from photomodel.sim import (
        MODEL_DISTANCE_MM,
        catalogue_garment,
        catalogue_names,
        hand_stereo_rig,
        model_station_camera,
        parse_conditions,
        render_model_photos,
        scene_rng,
        simulate_scene,
    )

    folder = work / "models"
    folder.mkdir(parents=True, exist_ok=True)
    names = catalogue_names(count)
    camera = model_station_camera()
    for name in names:
        path = folder / f"{name}.npz"
        if not path.exists():
            photo, background = render_model_photos(catalogue_garment(name), camera,
                                                    scene_rng(seed, "model", name))
            save_model(build_photo_model(photo, background, camera, MODEL_DISTANCE_MM,
                                         name=name).model, path)
    scenes_path = work / f"scenes-{count}-{seed}.pkl"
    if not scenes_path.exists():
        rig = hand_stereo_rig()
        scenes = []
        for k, name in enumerate(names):
            condition = CONDITIONS[k % len(CONDITIONS)]
            shot = simulate_scene(catalogue_garment(name), rig, parse_conditions(condition),
                                  scene_rng(seed, condition, name, k))
            scenes.append({"model": str(folder / f"{name}.npz"), "condition": condition,
                           "right": shot.right_bgr, "left": shot.left_bgr,
                           "T": shot.T_cam1_model})
        scenes_path.write_bytes(pickle.dumps(scenes))
    return scenes_path


# ----------------------------------------------------------------------------- the worker

def kept_bytes(obj: Any, seen: set[int] | None = None) -> int:
    """Bytes of the numpy arrays reachable from ``obj`` through containers, dataclasses,
    plain objects' attributes and :class:`~photomodel.fitness.PreparedModel`'s store (each
    array counted once, views of a counted array not again)."""
    seen = set() if seen is None else seen
    if id(obj) in seen or obj is None or isinstance(obj, (str, bytes, int, float, bool)):
        return 0
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        return 0 if obj.base is not None and id(obj.base) in seen else obj.nbytes
    if isinstance(obj, dict):
        return sum(kept_bytes(k, seen) + kept_bytes(v, seen) for k, v in obj.items())
    if isinstance(obj, (list, tuple, set, frozenset)):
        return sum(kept_bytes(v, seen) for v in obj)
    fields = ([getattr(obj, f.name) for f in dataclasses.fields(obj)]
              if dataclasses.is_dataclass(obj) else [])
    return sum(kept_bytes(v, seen) for v in [*fields, *getattr(obj, "__dict__", {}).values()])


def result_row(result: Any) -> dict[str, Any]:
    """What is compared of a ``LocateResult``: pose, fitness, score, found, and a digest of
    them and the search's pose and histories (equal digests: identical to the bit)."""
    search = result.search
    digest = hashlib.sha256()
    for a in (result.T_cam1_model, search.x, search.best_history, search.mean_history,
              np.array([result.fitness, result.score, search.fitness])):
        digest.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    return {"T_cam1_model": result.T_cam1_model.tolist(), "fitness": float(result.fitness),
            "score": float(result.score), "found": bool(result.found),
            "digest": digest.hexdigest()}


def worker(spec: dict[str, Any]) -> dict[str, Any]:
    """One tree's round (run in its subprocess): every model prepared, every scene located
    cold and warm; with ``spec["results"]`` also the locators' results and memory."""
    import photomodel
    from photomodel import Locator
    from photomodel.fitness import PreparedModel, StereoFeatures
    from photomodel.locate import locate_in_features
    from photomodel.model import load_model
    from photomodel.sim import hand_stereo_rig

    rig = hand_stereo_rig()
    scenes = pickle.loads(Path(spec["scenes"]).read_bytes())
    models = [load_model(s["model"]) for s in scenes]
    seed = int(spec["seed"])
    Locator(models[0], rig)(scenes[0]["right"], scenes[0]["left"], rng=seed)   # untimed
    out: dict[str, Any] = {"file": photomodel.__file__, "prepare": [], "prepare_cpu": [],
                           "cold": [], "warm": [], "memory_mb": [], "locator": [],
                           "cold_results": []}
    for model, scene in zip(models, scenes, strict=True):
        c0, t0 = time.process_time(), time.perf_counter()
        locator = Locator(model, rig)
        out["prepare"].append(time.perf_counter() - t0)
        out["prepare_cpu"].append(time.process_time() - c0)
        if spec["results"]:
            out["memory_mb"].append(kept_bytes(locator.prepared.kept) / 1e6)
            k = len(out["locator"])
            out["locator"].append(result_row(locator(scene["right"], scene["left"],
                                                     rng=seed + k)))
    for k, (model, scene) in enumerate(zip(models, scenes, strict=True)):
        features = StereoFeatures(rig, scene["right"], scene["left"])
        prepared = PreparedModel(model)
        for figure in ("cold", "warm"):
            t0 = time.perf_counter()
            result = locate_in_features(prepared, features, rng=seed + k)
            out[figure].append(time.perf_counter() - t0)
            if figure == "cold" and spec["results"]:
                out["cold_results"].append(result_row(result))
    return out


# ----------------------------------------------------------------------------- comparing

def compare_results(baseline: Sequence[dict[str, Any]], current: Sequence[dict[str, Any]]
                    ) -> dict[str, Any]:
    """Scene by scene: how many results are identical to the bit, how many differ in being
    found, and the largest position difference (mm)."""
    if len(baseline) != len(current):
        raise ValueError(f"results: {len(baseline)} baseline, {len(current)} current")
    moved = [float(np.linalg.norm(np.asarray(b["T_cam1_model"])[:3, 3]
                                  - np.asarray(c["T_cam1_model"])[:3, 3]))
             for b, c in zip(baseline, current, strict=True)]
    return {"scenes": len(moved),
            "identical": sum(b["digest"] == c["digest"]
                             for b, c in zip(baseline, current, strict=True)),
            "found_differs": sum(b["found"] != c["found"]
                                 for b, c in zip(baseline, current, strict=True)),
            "position_difference_max_mm": max(moved, default=0.0)}


def run_worker(tree: Tree, spec: dict[str, Any]) -> dict[str, Any]:
    """:func:`worker` in a subprocess of ``tree``; its output checked to come from the tree."""
    proc = subprocess.run([sys.executable, __file__, "--worker", json.dumps(spec)],
                          env=tree_env(tree), capture_output=True, text=True, timeout=3600,
                          check=False, cwd=REPO)
    if proc.returncode != 0:
        raise SystemExit(f"{tree.label} worker failed ({proc.returncode}):\n{proc.stderr}")
    out: dict[str, Any] = json.loads(proc.stdout.splitlines()[-1])
    if not Path(out["file"]).resolve().is_relative_to(tree.src.resolve()):
        raise SystemExit(f"{tree.label} worker ran {out['file']}, not under {tree.src}")
    return out


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline", default="HEAD",
                    help=f"git revision to compare with (default HEAD); {WORKTREE}: this "
                         f"working tree itself")
    ap.add_argument("--models", type=int, default=20, help="catalogue models (default 20)")
    ap.add_argument("--repeats", type=int, default=5, help="rounds (default 5)")
    ap.add_argument("--seed", type=int, default=0, help="simulation and search seed")
    ap.add_argument("--work", type=Path, default=REPO / "build" / "bench-prepare",
                    help="model files and scenes, kept between runs")
    ap.add_argument("--no-warmup", action="store_true",
                    help="skip photomodel warmup (the kernels must be cached already)")
    ap.add_argument("--out", type=Path, default=Path("build/bench/prepare.json"))
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker is not None:
        print(json.dumps(worker(json.loads(args.worker))))
        return {}
    if args.models < 1 or args.repeats < 1:
        ap.error("--models and --repeats must be >= 1")

    current = Tree("current", REPO / "src", None, None)
    worktree, created = None, False
    if args.baseline == WORKTREE:
        baseline = Tree("baseline", current.src, WORKTREE, None)
    else:
        sha = resolve_revision(args.baseline)
        worktree = Path(tempfile.gettempdir()) / f"photomodel-bench-{sha[:12]}"
        created = ensure_worktree(sha, worktree)
        baseline = Tree("baseline", worktree / "src", args.baseline, sha)
    trees = {"baseline": baseline, "current": current}
    try:
        scenes = build_data(args.work, args.models, args.seed)
        if not args.no_warmup:
            for label in dict.fromkeys(["baseline", "current"]):
                subprocess.run([sys.executable, "-m", "photomodel", "warmup"],
                               env=tree_env(trees[label]), check=True, stdout=sys.stderr,
                               timeout=1800)
        rounds: dict[str, list[dict[str, Any]]] = {label: [] for label in trees}
        loads = []
        for r in range(args.repeats):
            loads.append(os.getloadavg())
            for label in round_order(r):
                spec = {"scenes": str(scenes), "seed": args.seed, "results": r == 0}
                rounds[label].append(run_worker(trees[label], spec))
                print(f"round {r + 1}/{args.repeats} {label}: prepare median "
                      f"{1e3 * np.median(rounds[label][-1]['prepare']):.1f} ms",
                      file=sys.stderr, flush=True)
    finally:
        if created and worktree is not None:
            remove_worktree(worktree)

    def samples(label: str, figure: str) -> list[float]:
        return [x for one in rounds[label] for x in one[figure]]

    first = {label: rounds[label][0] for label in trees}
    out = {
        "meta": {**metadata("prepare", args.seed), "baseline": args.baseline,
                 "baseline_commit": baseline.sha, "models": args.models,
                 "repeats": args.repeats, "loadavg": loads},
        "figures": {figure: compare(samples("baseline", figure), samples("current", figure),
                                    args.seed, paired=True)
                    for figure in ("prepare", "prepare_cpu", "cold", "warm")},
        "memory_mb": {label: float(np.median(first[label]["memory_mb"])) for label in trees},
        "results": {kind: compare_results(first["baseline"][kind], first["current"][kind])
                    for kind in ("locator", "cold_results")},
        "samples": {label: rounds[label] for label in trees},
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(out, indent=1) + "\n")
    for figure, f in out["figures"].items():
        print(f"{figure:12s} baseline {1e3 * f['baseline']['median']:7.1f} ms   current "
              f"{1e3 * f['current']['median']:7.1f} ms   ratio {f['ratio_of_medians']:.2f} "
              f"(90 % {f['ratio_interval_90'][0]:.2f}-{f['ratio_interval_90'][1]:.2f})")
    print(f"memory per prepared model: {out['memory_mb']}")
    print(f"results: {out['results']}")
    return out


if __name__ == "__main__":
    main()
