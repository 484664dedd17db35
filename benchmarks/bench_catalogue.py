"""Benchmark: ``identify`` in catalogues of 100, 1,000 and 10,000 simulated garments.

The libraries hold the first N articles of the simulated catalogue (``cat-00000`` ...,
:func:`photomodel.sim.catalogue_spec`; 10 % are look-alike twins), each a photo-model built
from its simulated model photos like any station build. The model files are built once into
``--work/models/`` (2 processes; about 0.5 s a model) and each library is a directory of hard
links to the first N of them with its own index, so the libraries nest and are kept between
runs.

The scenes are the same for every library size: garments drawn from the first 100 articles
(which every library holds; their 10 look-alike pairs included) under the paper's set-up,
four lamps (``dim``, ``bright``, ``warm-light``, ``cool-light``) and clutter
(``distractors``, ``overlap``, ``gripper``), plus scenes with no library garment
(``no-target``: other garments and objects only; ``empty``). Per library size, in one
process, in alternating order per scene:

``locate``    the true model's ``Locator`` (prepared beforehand), what a cell that knows the
              garment runs;
``identify``  ``Identifier(ModelLibrary(lib), rig)`` (opened once, models prepared on first
              use, at most 64 kept), features included.

Reported per size: top-1 on garment scenes (by condition group), false accepts on scenes
without one, the pose errors of correctly identified garments in the paper's Table 1 form,
median identify and locate times and their ratio, the screening time (regions and bank), the
models verified, opening time of the library; and, with ``--cli``, the one-shot
``photomodel identify`` wall time (median of 5).

Run: ``.venv/bin/python benchmarks/bench_catalogue.py --sizes 100,1000``
(``--sizes 10000`` builds 10,000 model files first: about 45 min on 2 cores, 1.5 GB.)
Smoke: ``.venv/bin/python benchmarks/bench_catalogue.py --sizes 30 --garments 4 --negatives 2
--out build/bench-smoke/catalogue.json``
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
from _meta import metadata

GROUPS = {
    "paper": ("paper",),
    "light": ("dim", "bright", "warm-light", "cool-light"),
    "clutter": ("distractors", "overlap", "gripper"),
}
NEGATIVES = ("no-target", "empty")
TARGETS = {"top1_min": 0.99, "false_accept_max": 0.01, "screen_ms_1000": 10.0,
           "screen_ms_10000": 50.0, "identify_over_locate_1000": 5.0, "cli_s_1000": 3.0}


def _build_one(args: tuple[str, str, int]) -> str:
    name, folder, seed = args
    path = Path(folder) / f"{name}.npz"
    if path.exists():
        return name
    from photomodel.model import save_model
    from photomodel.sim import station_model

    model = station_model(name, seed)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    save_model(model, tmp)
    os.replace(tmp, path)
    return name


def build_library(work: Path, size: int, seed: int, workers: int) -> Path:
    """``work/lib-<size>``: hard links to the first ``size`` model files, indexed."""
    from photomodel.library import ModelLibrary
    from photomodel.sim import catalogue_names

    names = catalogue_names(size)
    pool = work / "models"
    pool.mkdir(parents=True, exist_ok=True)
    todo = [n for n in names if not (pool / f"{n}.npz").exists()]
    if todo:
        t0 = time.perf_counter()
        spawn = multiprocessing.get_context("spawn")   # the parent may run OpenMP already
        with ProcessPoolExecutor(workers, mp_context=spawn) as ex:
            for k, _ in enumerate(ex.map(_build_one, [(n, str(pool), seed) for n in todo],
                                         chunksize=8), 1):
                if k % 100 == 0 or k == len(todo):
                    print(f"built {k}/{len(todo)} models ({time.perf_counter() - t0:.0f} s)",
                          file=sys.stderr, flush=True)
    lib = work / f"lib-{size}"
    if not (lib / "index.json").exists():
        lib.mkdir(parents=True, exist_ok=True)
        for n in names:
            target = lib / f"{n}.npz"
            if not target.exists():
                os.link(pool / f"{n}.npz", target)
        t0 = time.perf_counter()
        ModelLibrary(lib).reindex()
        print(f"indexed {lib} in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    return lib


def make_scenes(garments: int, negatives: int, seed: int) -> list[dict[str, Any]]:
    """Stereo pairs with truth: ``garments`` garments of the first 100 articles, each under
    one condition of every group; ``negatives`` scenes of each negative condition."""
    from photomodel.sim import (
        catalogue_garment,
        catalogue_names,
        hand_stereo_rig,
        parse_conditions,
        scene_rng,
        simulate_scene,
    )

    rig = hand_stereo_rig()
    gen = np.random.default_rng([seed, 50])
    pool = catalogue_names(100)
    picks = gen.choice(len(pool), size=garments, replace=False)
    scenes = []
    for k, i in enumerate(picks):
        name = pool[int(i)]
        for group, conditions in GROUPS.items():
            cond = conditions[k % len(conditions)]
            shot = simulate_scene(catalogue_garment(name), rig, parse_conditions(cond),
                                  scene_rng(seed, cond, name, k))
            scenes.append({"id": f"{cond}_{name}", "truth": name, "group": group,
                           "condition": cond, "right": shot.right_bgr, "left": shot.left_bgr,
                           "T": shot.T_cam1_model,
                           "visible": float(shot.info["visible_fraction"][0])})
    for cond in NEGATIVES:
        for k in range(negatives):
            shot = simulate_scene(None, rig, parse_conditions(cond), scene_rng(seed, cond, k))
            scenes.append({"id": f"{cond}_{k:04d}", "truth": None, "group": cond,
                           "condition": cond, "right": shot.right_bgr, "left": shot.left_bgr,
                           "T": None, "visible": 0.0})
    return scenes


def _errors(T_est: np.ndarray, T_true: np.ndarray) -> dict[str, float]:
    from photomodel.geometry import in_plane_angle_rad

    d = T_est[:3, 3] - T_true[:3, 3]
    dtheta = np.degrees(in_plane_angle_rad(T_est) - in_plane_angle_rad(T_true))
    dtheta = float((dtheta + 180.0) % 360.0 - 180.0)
    return {"x": float(d[0]), "y": float(d[1]), "z": float(d[2]), "theta": dtheta}


def run_size(lib: Path, scenes: list[dict[str, Any]], seed: int) -> dict[str, Any]:
    """Every scene through one Identifier of ``lib`` and the true model's Locator."""
    from photomodel.fitness import StereoFeatures, scene_regions
    from photomodel.identify import Identifier
    from photomodel.library import ModelLibrary
    from photomodel.locate import Locator
    from photomodel.sim import hand_stereo_rig

    rig = hand_stereo_rig()
    t0 = time.perf_counter()
    identifier = Identifier(ModelLibrary(lib), rig)
    open_s = time.perf_counter() - t0
    warm = scenes[0]
    identifier(warm["right"], warm["left"], rng=0)       # kernels loaded
    rows = []
    library = ModelLibrary(lib)
    locators: dict[str, Any] = {}
    for k, sc in enumerate(scenes):
        truth = sc["truth"]
        if truth is not None and truth not in locators:   # apart from the identifier's own
            locators[truth] = Locator(library.load_entry(identifier.entries[truth]), rig)
        cold = truth is not None and truth not in identifier.prepared
        locator = locators.get(truth) if truth is not None else None
        order = ("locate", "identify") if k % 2 == 0 else ("identify", "locate")
        times: dict[str, float] = {}
        result = None
        truth_result = None
        for what in order:
            if what == "locate" and locator is None:
                continue
            t1 = time.perf_counter()
            if what == "locate":
                assert locator is not None
                truth_result = locator(sc["right"], sc["left"], rng=k)
            else:
                result = identifier(sc["right"], sc["left"], rng=k)
            times[what] = time.perf_counter() - t1
        assert result is not None
        features = StereoFeatures(rig, sc["right"], sc["left"])
        t1 = time.perf_counter()
        regions = scene_regions(features, (float(identifier.space.lower[2]),
                                           float(identifier.space.upper[2])),
                                identifier.config.scene)
        t2 = time.perf_counter()
        evidence = identifier.bank.evidence(regions, identifier.config.bank)
        t3 = time.perf_counter()
        rank = None
        if sc["truth"] is not None:
            i = identifier.names.index(sc["truth"])
            rank = int(np.sum(evidence > evidence[i]))
        row = {"id": sc["id"], "group": sc["group"], "truth": sc["truth"],
               "answer": result.model, "score": result.score, "visible": sc["visible"],
               "answer_evidence": next((c.evidence for c in result.candidates
                                        if c.model == result.model), None),
               "runner_up_score": None if result.runner_up is None else result.runner_up.score,
               "correct": result.model == sc["truth"],
               "searched": sum(c.result is not None for c in result.candidates),
               "screen_rank": rank, "identify_s": times["identify"], "cold": cold,
               "locate_s": times.get("locate"),
               "truth_located": None if truth_result is None else bool(truth_result.found),
               "truth_score": None if truth_result is None else float(truth_result.score),
               "regions_ms": 1e3 * (t2 - t1),
               "bank_ms": 1e3 * (t3 - t2)}
        if row["correct"] and sc["T"] is not None and result.best is not None:
            row["errors"] = _errors(result.best.T_cam1_model, sc["T"])
        rows.append(row)
        print(f"{lib.name} {sc['id']}: {result.model} ({row['searched']} searched, screen "
              f"rank {rank}) identify {times['identify']:.3f} s"
              + (f", locate {times['locate']:.3f} s" if "locate" in times else ""),
              file=sys.stderr, flush=True)
    return summarise(rows, open_s, identifier)


def summarise(rows: list[dict[str, Any]], open_s: float, identifier: Any) -> dict[str, Any]:
    garment = [r for r in rows if r["truth"] is not None]
    negative = [r for r in rows if r["truth"] is None]
    by_group = {g: float(np.mean([r["correct"] for r in garment if r["group"] == g]))
                for g in GROUPS if any(r["group"] == g for r in garment)}
    errs = [r["errors"] for r in garment if "errors" in r]
    table1 = {k: {"mean": float(np.mean([e[k] for e in errs])),
                  "sd": float(np.std([e[k] for e in errs]))} for k in ("x", "y", "z", "theta")
              } if errs else {}
    located = [r for r in garment if r["locate_s"]]
    ratio = (float(np.median([r["identify_s"] for r in located])
                   / np.median([r["locate_s"] for r in located])) if located else None)
    screen = [r["regions_ms"] + r["bank_ms"] for r in rows]
    return {
        "models": len(identifier), "open_s": open_s,
        "garment_scenes": len(garment), "negative_scenes": len(negative),
        "top1": float(np.mean([r["correct"] for r in garment])) if garment else None,
        "top1_by_group": by_group,
        "top1_where_true_model_located": float(np.mean(
            [r["correct"] for r in garment if r["truth_located"]] or [np.nan])),
        "true_model_located": float(np.mean([bool(r["truth_located"]) for r in garment]))
        if garment else None,
        "true_model_screened_first": float(np.mean([r["screen_rank"] == 0 for r in garment]))
        if garment else None,
        "false_accepts": float(np.mean([r["answer"] is not None for r in negative]))
        if negative else None,
        "pose_errors_table1": table1,
        "identify_median_s": float(np.median([r["identify_s"] for r in garment])),
        "identify_cold_median_s": float(np.median([r["identify_s"] for r in garment
                                                   if r["cold"]] or [np.nan])),
        "identify_warm_median_s": float(np.median([r["identify_s"] for r in garment
                                                   if not r["cold"]] or [np.nan])),
        "identify_negative_median_s": float(np.median([r["identify_s"] for r in negative]))
        if negative else None,
        "identify_negative_by_condition_median_s": {
            g: float(np.median([r["identify_s"] for r in negative if r["group"] == g]))
            for g in NEGATIVES if any(r["group"] == g for r in negative)},
        "locate_median_s": float(np.median([r["locate_s"] for r in located]))
        if located else None,
        "identify_over_locate": ratio,
        "screen_median_ms": float(np.median(screen)),
        "regions_median_ms": float(np.median([r["regions_ms"] for r in rows])),
        "bank_median_ms": float(np.median([r["bank_ms"] for r in rows])),
        "searched_median": float(np.median([r["searched"] for r in rows])),
        "prepared_cache": vars(identifier.stats()),
        "rows": rows,
    }


def cli_identify(lib: Path, scene: dict[str, Any], repeats: int = 5) -> dict[str, Any]:
    """One-shot ``photomodel identify`` wall time on one scene (median of ``repeats``)."""
    from photomodel.camera import save_stereo
    from photomodel.image import write_image
    from photomodel.sim import hand_stereo_rig

    exe = Path(sys.executable).with_name("photomodel")
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        save_stereo(d / "stereo.yaml", hand_stereo_rig())
        write_image(d / "right.png", scene["right"])
        write_image(d / "left.png", scene["left"])
        cmd = [str(exe), "identify", "--models", str(lib), "--stereo", str(d / "stereo.yaml"),
               "--right", str(d / "right.png"), "--left", str(d / "left.png"), "--json"]
        times, answer = [], None
        for _ in range(repeats):
            t0 = time.perf_counter()
            out = subprocess.run(cmd, capture_output=True, text=True, check=True)
            times.append(time.perf_counter() - t0)
            answer = json.loads(out.stdout)["model"]
    return {"median_s": float(np.median(times)), "times_s": times, "answer": answer,
            "truth": scene["truth"]}


def _rss_mb(pid: int) -> float:
    """Resident memory of process ``pid`` (MB, from /proc)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def service_memory(lib: Path, scenes: list[dict[str, Any]], requests: int = 20
                   ) -> dict[str, Any]:
    """``photomodel serve`` on ``lib`` as its own process: seconds until ``/health`` says ok,
    resident memory then, and after ``requests`` ``/identify`` requests on loopback."""
    import socket
    import urllib.request

    import cv2

    from photomodel.camera import save_stereo
    from photomodel.sim import hand_stereo_rig

    def png(image: np.ndarray) -> bytes:
        return cv2.imencode(".png", image)[1].tobytes()

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    exe = Path(sys.executable).with_name("photomodel")
    with tempfile.TemporaryDirectory() as tmp:
        stereo = Path(tmp) / "stereo.yaml"
        save_stereo(stereo, hand_stereo_rig())
        t0 = time.perf_counter()
        proc = subprocess.Popen([str(exe), "serve", "--stereo", str(stereo), "--models",
                                 str(lib), "--port", str(port), "--log-level", "warning"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            url = f"http://127.0.0.1:{port}"
            health: dict[str, Any] = {}
            while time.perf_counter() - t0 < 600:
                try:
                    with urllib.request.urlopen(f"{url}/health", timeout=5) as r:
                        health = json.loads(r.read())
                    if health.get("status") == "ok":
                        break
                except OSError:
                    pass
                time.sleep(0.2)
            ready_s = time.perf_counter() - t0
            rss_ready = _rss_mb(proc.pid)
            import httpx

            with httpx.Client(timeout=120) as client:
                for sc in (scenes * requests)[:requests]:
                    files = {"right": ("r.png", png(sc["right"])),
                             "left": ("l.png", png(sc["left"]))}
                    client.post(f"{url}/identify", files=files).raise_for_status()
                health = client.get(f"{url}/health").json()
            return {"ready_s": ready_s, "rss_ready_mb": rss_ready,
                    "rss_after_mb": _rss_mb(proc.pid), "requests": requests,
                    "prepared": health.get("prepared"), "models": health.get("models")}
        finally:
            proc.terminate()
            proc.wait(timeout=30)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--sizes", default="100,1000")
    p.add_argument("--garments", type=int, default=30,
                   help="garments of the first 100 articles, each in every group")
    p.add_argument("--negatives", type=int, default=20, help="scenes per negative condition")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--cli", action="store_true", help="also time one-shot CLI identify")
    p.add_argument("--service", action="store_true",
                   help="also measure the service's warm-up and memory per library")
    p.add_argument("--work", type=Path, default=Path("build/bench-catalogue"))
    p.add_argument("--out", type=Path,
                   default=Path(__file__).parent / "results" / "catalogue.json")
    args = p.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",") if s]
    t0 = time.perf_counter()
    libs = {n: build_library(args.work, n, args.seed, args.workers) for n in sizes}
    scenes = make_scenes(min(args.garments, min(100, *sizes)), args.negatives, args.seed)
    results: dict[str, Any] = {}
    for n in sizes:
        results[str(n)] = run_size(libs[n], scenes, args.seed)
        if args.cli:
            results[str(n)]["cli_identify"] = cli_identify(libs[n], scenes[0])
        if args.service:
            results[str(n)]["service"] = service_memory(libs[n], scenes)
        r = results[str(n)]
        print(f"{n} models: top-1 {r['top1']:.3f} {r['top1_by_group']}, false accepts "
              f"{r['false_accepts']}, identify/locate {r['identify_over_locate']:.2f}, screen "
              f"{r['screen_median_ms']:.1f} ms, searched {r['searched_median']}",
              file=sys.stderr)
    out = {**metadata("catalogue", args.seed),
           "settings": {"sizes": sizes, "garments": args.garments,
                        "negatives": args.negatives, "groups": GROUPS,
                        "numba_threads": os.environ.get("NUMBA_NUM_THREADS", "default")},
           "targets": TARGETS, "results": results, "wall_seconds": time.perf_counter() - t0}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_name(f".{args.out.name}.tmp")
    tmp.write_text(json.dumps(out, indent=1) + "\n")
    os.replace(tmp, args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
