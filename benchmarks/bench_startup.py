"""Benchmark: what a user of the command line and of the Python API waits for, against a
baseline revision in the same run.

Issue 40 asks that nothing gets slower: ``locate`` in process and the one-shot CLI within 5 %
of before. "Before" is a git revision (``--baseline``, by default a1e04a0, the commit before
the reliability work), checked out in a git worktree; "after" is this working tree, as it is
(uncommitted edits included). Each runs from its own source tree in its own subprocesses, with
this Python (``PYTHONPATH=<tree>/src``); every subprocess's ``photomodel.__file__`` is checked
to lie under the intended tree before anything is timed.

Figures, each for the baseline and the current tree:

``help``        ``photomodel --help``: wall time of the process;
``error``       the error path, ``photomodel locate --model missing.npz --stereo S --right R
                --left L`` (exit code 2, one line on stderr naming the file);
``locate``      one-shot ``photomodel locate --model M --stereo S --right R --left L --json
                --seed 1`` on a warm numba cache (the process's wall time; the ``seconds``
                its JSON reports, the locate alone, is kept as ``locate_inner``);
``inprocess``   per round, one worker subprocess per tree runs the tree's API: it builds
                ``pm.Locator(model, rig)`` for every model, timed (``prepare``), then waits
                on its pipe and locates the stereo pair it is sent. Each worker's first pair
                (``first_pair``: the process loads the compiled kernels), then ``--calls``
                rounds over every scene of ``locator(right, left, rng=seed)``, the two
                workers taking turns call by call (``pair``: median, p90, p99 over all calls
                of all rounds; ``pair_cpu``: the worker's CPU seconds in each call, all
                threads, less sensitive to other processes than the wall clock).

The data: ``photomodel simulate`` (the current tree) writes ``--garments`` x ``--scenes``
seeded scenes into a temporary directory; each tree builds its photo-models with its own
``photomodel build`` (``--models own``, what a user of that revision gets) or both use the
baseline's build (``--models shared``). Which members of the two builds differ and whether
each tree reads the other's file is recorded. Before timing, ``photomodel warmup --all`` runs
for each tree: numba caches the compiled kernels beside each source file, so a fresh baseline
worktree compiles every kernel once (1-2 minutes on two cores); a worktree already there at
the right revision (``--worktree``) keeps its cache. Then one untimed round of every command
per tree (Python's bytecode caches, the OS file cache).

Interleaved: in each of ``--repeats`` rounds, for each figure, the two trees run one after
the other, the order alternating from round to round (in process: from call to call), so that
the machine's load falls on both alike; every figure's samples are pairs taken side by side.
Every command's exit code and output are checked; the poses both trees find are compared.
Reported per figure: median (p90 from 10 samples, p99 from 100), the ratio of the medians
current / baseline, the median of the pairwise ratios, a seeded bootstrap 90 % interval of
the ratio of medians, and ``pass`` when the ratio of medians is at most 1.05 (``fail``
otherwise: a miss is reported, the exit code stays 0). The load average before and after and
at each round is kept: on a loaded machine read the interval, not only the ratio. Numba's
parallel kernels suffer most from other processes (on two busy cores a 20 ms pair can take
0.5-0.9 s, whichever tree runs): ``--numba-threads 1`` holds every subprocess to one thread.
The current tree's sources are fingerprinted at every round: an edit during the run (its
kernels then compile again) is reported with the round.

Output: ``--out`` (JSON: meta with the commit and versions, the baseline revision, settings,
data, load, per figure the samples and statistics) and a table on stdout.

Run: ``.venv/bin/python benchmarks/bench_startup.py`` (7 rounds, 2 garments x 3 scenes x 5
calls in process: about 4 minutes on two cores once the baseline's kernels are compiled).
Smoke: ``--quick`` (2 rounds, one scene, two calls); ``--baseline WORKTREE`` compares this
tree with itself (no worktree, no compile): the noise floor of the method.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from _meta import metadata

REPO = Path(__file__).resolve().parents[1]
DEFAULT_BASELINE = "a1e04a0"
WORKTREE = "WORKTREE"
"""``--baseline`` value meaning this working tree itself (no git worktree)."""
TOLERANCE = 0.05
"""Issue 40: current / baseline at most 1 + TOLERANCE."""
KINDS = ("help", "error", "locate", "inprocess")
P90_MIN_SAMPLES = 10
P99_MIN_SAMPLES = 100
BOOTSTRAP_RESAMPLES = 2000
RESULT_MARK = "BENCH_STARTUP_JSON "

FIGURES: dict[str, str] = {
    "help": "photomodel --help",
    "error": "locate, missing model (exit 2)",
    "locate": "locate one-shot CLI",
    "locate_inner": "locate one-shot: its JSON seconds",
    "prepare": "in process: Locator(model, rig)",
    "first_pair": "in process: first pair",
    "pair": "in process: a pair",
    "pair_cpu": "in process: a pair, CPU time (all threads)",
}
"""The figures in table order: key -> what is timed."""
TAIL_FIGURES = {"pair": "p99"}
"""Figures whose tail is judged as well (ratio of p99s, when both have enough samples)."""


# ----------------------------------------------------------------------------- statistics

def summarise(samples: Sequence[float]) -> dict[str, Any]:
    """Median, mean, min, max and, with enough samples, p90 and p99 of ``samples`` (s).

    p90 needs at least :data:`P90_MIN_SAMPLES` samples and p99 :data:`P99_MIN_SAMPLES` (None
    otherwise); an empty sequence gives ``n = 0`` and None everywhere.
    """
    x = np.asarray(samples, dtype=np.float64)
    n = int(x.size)
    if n == 0:
        return {"n": 0, "median": None, "mean": None, "min": None, "max": None, "p90": None,
                "p99": None}
    return {"n": n, "median": float(np.median(x)), "mean": float(x.mean()),
            "min": float(x.min()), "max": float(x.max()),
            "p90": float(np.percentile(x, 90)) if n >= P90_MIN_SAMPLES else None,
            "p99": float(np.percentile(x, 99)) if n >= P99_MIN_SAMPLES else None}


def ratio(current: float | None, baseline: float | None) -> float | None:
    """``current / baseline``; None when either is missing or the baseline is not positive."""
    if current is None or baseline is None or not baseline > 0:
        return None
    return float(current / baseline)


def verdict(r: float | None, tolerance: float = TOLERANCE) -> str:
    """``"pass"`` when ratio ``r`` is at most ``1 + tolerance``, ``"fail"`` above, ``"n/a"``
    without a ratio."""
    if r is None:
        return "n/a"
    return "pass" if r <= 1.0 + tolerance + 1e-12 else "fail"


def paired_ratios(baseline: Sequence[float], current: Sequence[float]) -> list[float]:
    """Round by round ``current[i] / baseline[i]`` (samples taken side by side)."""
    if len(baseline) != len(current):
        raise ValueError(f"paired samples: {len(baseline)} baseline, {len(current)} current")
    return [c / b for b, c in zip(baseline, current, strict=True) if b > 0]


def bootstrap_ratio_interval(baseline: Sequence[float], current: Sequence[float], seed: int,
                             level: float = 0.90, statistic: str = "median",
                             paired: bool = False, resamples: int = BOOTSTRAP_RESAMPLES
                             ) -> tuple[float, float] | None:
    """A percentile bootstrap interval (``level``) of ``stat(current) / stat(baseline)``
    (``statistic``: ``"median"`` or ``"p99"``): with ``paired`` the pairs ``(baseline[i],
    current[i])`` are resampled together (samples taken side by side share the machine's
    load, and a mix of scenes or models stays balanced), else each group on its own. None
    with fewer than two samples in a group."""
    b = np.asarray(baseline, dtype=np.float64)
    c = np.asarray(current, dtype=np.float64)
    if b.size < 2 or c.size < 2:
        return None
    if paired and b.size != c.size:
        raise ValueError(f"paired samples: {b.size} baseline, {c.size} current")
    rng = np.random.default_rng(seed)
    bi = rng.integers(0, b.size, size=(resamples, b.size))
    ci = bi if paired else rng.integers(0, c.size, size=(resamples, c.size))
    if statistic == "median":
        sb, sc = np.median(b[bi], axis=1), np.median(c[ci], axis=1)
    elif statistic == "p99":
        sb, sc = np.percentile(b[bi], 99, axis=1), np.percentile(c[ci], 99, axis=1)
    else:
        raise ValueError(f"statistic: expected 'median' or 'p99', got {statistic!r}")
    r = sc / sb
    tail = (1.0 - level) / 2.0 * 100.0
    return float(np.percentile(r, tail)), float(np.percentile(r, 100.0 - tail))


def compare(baseline: Sequence[float], current: Sequence[float], seed: int,
            paired: bool = False, tail: str | None = None,
            tolerance: float = TOLERANCE) -> dict[str, Any]:
    """Both groups' statistics, the ratio of medians, its bootstrap interval and verdict; the
    median of the pairwise ratios when ``paired`` (samples taken side by side, resampled
    together); with ``tail="p99"`` also the ratio of the p99s and its verdict (None /
    ``"n/a"`` without enough samples)."""
    sb, sc = summarise(baseline), summarise(current)
    r = ratio(sc["median"], sb["median"])
    out: dict[str, Any] = {
        "baseline": sb, "current": sc, "ratio_of_medians": r,
        "ratio_interval_90": bootstrap_ratio_interval(baseline, current, seed, paired=paired),
        "criterion": f"ratio_of_medians <= {1.0 + tolerance:.2f}", "verdict": verdict(r, tolerance),
        "paired_ratio_median": None}
    if paired:
        pr = paired_ratios(baseline, current)
        out["paired_ratio_median"] = float(np.median(pr)) if pr else None
    if tail == "p99":
        rt = ratio(sc["p99"], sb["p99"])
        out["ratio_of_p99"] = rt
        out["ratio_of_p99_interval_90"] = (
            bootstrap_ratio_interval(baseline, current, seed, statistic="p99", paired=paired)
            if rt is not None else None)
        out["verdict_p99"] = verdict(rt, tolerance)
    return out


def round_order(round_index: int) -> tuple[str, str]:
    """Which tree runs first in round ``round_index``: the baseline in even rounds."""
    return ("baseline", "current") if round_index % 2 == 0 else ("current", "baseline")


# ----------------------------------------------------------------------------- trees

@dataclass(frozen=True)
class Tree:
    """A source tree to run: ``label`` (``baseline`` / ``current``), its ``src`` folder (put on
    ``PYTHONPATH``), the revision asked for and its commit (None: the working tree), and the
    numba threads of its processes (None: numba's default)."""

    label: str
    src: Path
    rev: str | None
    sha: str | None
    numba_threads: int | None = None


def _git(*args: str, cwd: Path = REPO, strip: bool = True) -> str:
    out = subprocess.run(["git", "-C", str(cwd), *args], capture_output=True, text=True,
                         check=True, timeout=120).stdout
    return out.strip() if strip else out


def resolve_revision(rev: str) -> str:
    """The full commit hash of ``rev`` in this repository."""
    try:
        return _git("rev-parse", "--verify", f"{rev}^{{commit}}")
    except subprocess.CalledProcessError as exc:
        raise SystemExit(f"--baseline: {rev!r} is not a commit of {REPO}: "
                         f"{exc.stderr.strip()}") from None


def ensure_worktree(sha: str, path: Path) -> bool:
    """A detached git worktree of ``sha`` at ``path``; True when this call created it (an
    existing one at the same commit is reused with its numba cache)."""
    if path.exists():
        try:
            head = _git("rev-parse", "HEAD", cwd=path)
        except subprocess.CalledProcessError:
            head = ""
        if head != sha:
            raise SystemExit(f"--worktree: {path} exists but is not a checkout of {sha[:12]} "
                             f"(HEAD {head[:12] or 'unknown'}); remove it or choose another path")
        return False
    _git("worktree", "add", "--detach", str(path), sha)
    return True


def remove_worktree(path: Path) -> None:
    """``git worktree remove --force path``."""
    _git("worktree", "remove", "--force", str(path))


def tree_env(tree: Tree) -> dict[str, str]:
    """The environment of a tree's subprocesses: this one with ``PYTHONPATH=<src>`` (and
    ``NUMBA_NUM_THREADS`` with ``--numba-threads``)."""
    env = dict(os.environ)
    env["PYTHONPATH"] = str(tree.src)
    if tree.numba_threads is not None:
        env["NUMBA_NUM_THREADS"] = str(tree.numba_threads)
    return env


def cli_prefix(via: str) -> list[str]:
    """How the command is started: the ``photomodel`` script beside this Python (what a user
    types; it imports ``photomodel.cli`` through ``sys.path``, so ``PYTHONPATH`` chooses the
    tree) or ``python -m photomodel``."""
    script = Path(sys.executable).parent / "photomodel"
    if via == "script" and script.is_file():
        return [str(script)]
    return [sys.executable, "-m", "photomodel"]


PROBE = """
import json, sys
import photomodel as pm
print(json.dumps({"file": pm.__file__, "locator": hasattr(pm, "Locator"),
                  "read_image": hasattr(pm, "read_image"), "python": sys.executable}))
"""


def probe(tree: Tree, cwd: Path) -> dict[str, Any]:
    """Which ``photomodel`` a subprocess of ``tree`` imports; SystemExit when it is not the
    tree's."""
    proc = subprocess.run([sys.executable, "-c", PROBE], env=tree_env(tree), cwd=cwd,
                          capture_output=True, text=True, timeout=120)
    if proc.returncode != 0:
        raise SystemExit(f"{tree.label}: cannot import photomodel from {tree.src}: "
                         f"{proc.stderr.strip()[-2000:]}")
    info = json.loads(proc.stdout.strip().splitlines()[-1])
    check_under(info["file"], tree)
    return info


def check_under(file: str, tree: Tree) -> None:
    """SystemExit unless ``file`` lies under ``tree.src``."""
    if not Path(file).resolve().is_relative_to(tree.src.resolve()):
        raise SystemExit(f"{tree.label}: photomodel imported from {file}, not from {tree.src}")


def source_fingerprint(src: Path) -> str:
    """A hash of every ``.py`` file's path and content under ``src`` (edits during a run show
    as a changed fingerprint)."""
    h = hashlib.sha256()
    for p in sorted(src.rglob("*.py")):
        h.update(str(p.relative_to(src)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


# ----------------------------------------------------------------------------- running

@dataclass(frozen=True)
class Timed:
    """A finished command: wall and CPU seconds (user + system of the child), output."""

    wall_s: float
    cpu_s: float
    returncode: int
    stdout: str
    stderr: str


def run_timed(cmd: Sequence[str], env: dict[str, str], cwd: Path,
              timeout_s: float = 600.0) -> Timed:
    """Run ``cmd`` and time it (wall clock around the whole process; CPU of the child)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(list(cmd), env=env, cwd=cwd, capture_output=True, text=True,
                          timeout=timeout_s)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return Timed(wall, cpu, proc.returncode, proc.stdout, proc.stderr)


def _expect(t: Timed, rc: int, what: str) -> None:
    if t.returncode != rc:
        raise RuntimeError(f"{what}: exit code {t.returncode}, expected {rc}; stderr: "
                           f"{t.stderr.strip()[-2000:]}")


def _log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


WORKER = """
import json, sys, time
spec = json.loads(sys.argv[1])


def reply(obj):
    sys.stdout.write(spec["mark"] + json.dumps(obj) + "\\n")
    sys.stdout.flush()


import numba
import photomodel as pm
rig = pm.load_stereo(spec["stereo"])
if hasattr(pm, "read_image"):
    read = pm.read_image
else:
    import cv2
    read = lambda p: cv2.imread(p, cv2.IMREAD_COLOR)
pairs = [(s["name"], s["garment"], read(s["right"]), read(s["left"])) for s in spec["scenes"]]
locators, prepare_s = {}, []
for garment, path in spec["models"].items():
    model = pm.load_model(path)
    t = time.perf_counter()
    if hasattr(pm, "Locator"):
        locators[garment] = pm.Locator(model, rig)
    else:
        from photomodel.locate import locate
        locators[garment] = (lambda m: lambda r, l, rng: locate(m, rig, r, l, rng=rng))(model)
    prepare_s.append(time.perf_counter() - t)
reply({"file": pm.__file__, "numba_threads": numba.get_num_threads(),
       "api": "Locator" if hasattr(pm, "Locator") else "locate", "prepare_s": prepare_s})
for line in sys.stdin:
    k = json.loads(line)
    if k is None:
        break
    name, garment, right, left = pairs[k]
    c, t = time.process_time(), time.perf_counter()
    res = locators[garment](right, left, rng=spec["seed"])
    s, cpu = time.perf_counter() - t, time.process_time() - c
    reply({"scene": name, "seconds": s, "cpu_seconds": cpu, "found": bool(res.found),
           "score": float(res.score),
           "position_mm": [float(v) for v in res.T_cam1_model[:3, 3]]})
"""


class Worker:
    """A subprocess of a tree that prepares every model (:data:`WORKER`) and then locates one
    stereo pair per :meth:`call`, so that two trees' workers can take turns call by call
    (the one waiting on its pipe takes no CPU)."""

    def __init__(self, tree: Tree, spec: dict[str, Any], cwd: Path) -> None:
        self.tree = tree
        self._stderr = tempfile.TemporaryFile(mode="w+")
        self._proc = subprocess.Popen(
            [sys.executable, "-c", WORKER, json.dumps({**spec, "mark": RESULT_MARK})],
            env=tree_env(tree), cwd=cwd, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=self._stderr, text=True, bufsize=1)
        self.ready = self._read()
        check_under(self.ready["file"], tree)

    def _read(self) -> dict[str, Any]:
        assert self._proc.stdout is not None
        for line in self._proc.stdout:
            if line.startswith(RESULT_MARK):
                return json.loads(line[len(RESULT_MARK):])
        self._proc.wait()
        self._stderr.seek(0)
        raise RuntimeError(f"{self.tree.label}: in-process worker ended (exit code "
                           f"{self._proc.returncode}): {self._stderr.read()[-2000:]}")

    def call(self, scene: int) -> dict[str, Any]:
        """Locate scene number ``scene``: its seconds, CPU seconds and result."""
        assert self._proc.stdin is not None
        self._proc.stdin.write(json.dumps(scene) + "\n")
        self._proc.stdin.flush()
        return self._read()

    def close(self) -> None:
        """End the worker (and check that it ended well)."""
        assert self._proc.stdin is not None
        try:
            self._proc.stdin.write("null\n")
            self._proc.stdin.close()
        except BrokenPipeError:
            pass
        rc = self._proc.wait(timeout=120)
        self._stderr.close()
        if rc != 0:
            raise RuntimeError(f"{self.tree.label}: in-process worker: exit code {rc}")


def in_process_round(trees: dict[str, Tree], order: Sequence[str], spec: dict[str, Any],
                     calls: int, cwd: Path) -> dict[str, dict[str, Any]]:
    """One in-process round: each tree's worker started (one after the other, in ``order``),
    each model prepared; then the first pair of each; then ``calls`` rounds over the scenes,
    the two workers taking turns call by call (who goes first alternating from call to call).
    Per tree: the ready message (``prepare_s``), ``first_pair`` and ``calls``."""
    workers: dict[str, Worker] = {}
    try:
        for label in order:
            workers[label] = Worker(trees[label], {**spec, "models": spec["models"][label]},
                                    cwd)
        out = {label: {**w.ready, "calls": []} for label, w in workers.items()}
        for label in order:
            out[label]["first_pair"] = workers[label].call(0)
        n = len(spec["scenes"])
        for k in range(calls * n):
            turn = order if k % 2 == 0 else tuple(reversed(order))
            for label in turn:
                out[label]["calls"].append(workers[label].call(k % n))
    finally:
        for w in workers.values():
            w.close()
    return out


# ----------------------------------------------------------------------------- data

@dataclass(frozen=True)
class Data:
    """The simulated inputs: the stereo calibration, the scenes (name, garment, right, left)
    and, per tree label, each garment's model file."""

    root: Path
    stereo: Path
    scenes: tuple[dict[str, str], ...]
    models: dict[str, dict[str, str]]


def model_file_differences(a: Path, b: Path) -> list[str] | None:
    """The members in which two ``.npz`` model files differ (missing from one, or other
    values), sorted; ``[]``: the same arrays; None when one cannot be read."""
    try:
        with np.load(a, allow_pickle=False) as za, np.load(b, allow_pickle=False) as zb:
            names = set(za.files) | set(zb.files)
            return sorted(k for k in names if k not in za.files or k not in zb.files
                          or not np.array_equal(za[k], zb[k]))
    except (OSError, ValueError):
        return None


def prepare_data(work: Path, trees: dict[str, Tree], cli: list[str], garments: Sequence[str],
                 scenes: int, seed: int, models: str,
                 kinds: Sequence[str] = KINDS) -> tuple[Data, dict[str, Any]]:
    """Simulate the scenes with the current tree and build each tree's models; the data and
    what was found out about the model files. Only what ``kinds`` needs: nothing for
    ``help`` alone, no models for ``help`` and ``error``."""
    current = trees["current"]
    data_dir = work / "data"
    if set(kinds) <= {"help"}:
        return Data(data_dir, data_dir / "stereo.yaml", (), {}), {"simulated": False}
    _log(f"simulating {len(garments)} garment(s) x {scenes} scene(s) (seed {seed}) ...")
    t = run_timed([*cli, "simulate", "--out", str(data_dir), "--garments", ",".join(garments),
                   "--scenes", str(scenes), "--seed", str(seed)], tree_env(current), work)
    _expect(t, 0, "simulate")
    _log(f"simulated in {t.wall_s:.1f} s")
    scene_list = []
    for g in garments:
        for k in range(scenes):
            d = data_dir / "scenes" / f"paper_{g}_{k:04d}"
            if not (d / "right.png").is_file():
                raise RuntimeError(f"simulate wrote no {d / 'right.png'}")
            scene_list.append({"name": d.name, "garment": g, "right": str(d / "right.png"),
                               "left": str(d / "left.png")})
    if set(kinds) <= {"help", "error"}:
        return (Data(data_dir, data_dir / "stereo.yaml", tuple(scene_list), {}),
                {"simulated": True, "models": None})
    built: dict[Path, dict[str, str]] = {}
    build_s: dict[str, list[float]] = {}
    for label, tree in trees.items():
        if tree.src in built:
            continue
        out_dir = work / "models" / label
        out_dir.mkdir(parents=True)
        built[tree.src] = {}
        build_s[label] = []
        for g in garments:
            path = out_dir / f"{g}.npz"
            b = run_timed([*cli, "build", "--photo", str(data_dir / "models" / g / "photo.bmp"),
                           "--background", str(data_dir / "models" / g / "background.bmp"),
                           "--camera", str(data_dir / "model_camera.yaml"), "--out", str(path),
                           "--name", g, "--no-preview"], tree_env(tree), work)
            _expect(b, 0, f"{label}: build {g}")
            built[tree.src][g] = str(path)
            build_s[label].append(b.wall_s)
    _log("built the models: " + ", ".join(f"{label} {sum(v):.1f} s"
                                         for label, v in build_s.items()))
    own = {label: built[tree.src] for label, tree in trees.items()}
    info: dict[str, Any] = {"simulated": True, "build_seconds": build_s}
    if trees["baseline"].src != current.src:
        g = garments[0]
        info["build_differences"] = {
            g: model_file_differences(Path(own["baseline"][g]), Path(own["current"][g]))
            for g in garments}
        reads = {}
        for reader, writer in (("current", "baseline"), ("baseline", "current")):
            r = run_timed([sys.executable, "-c", "import photomodel as pm, sys; "
                           "pm.load_model(sys.argv[1])", own[writer][g]],
                          tree_env(trees[reader]), work)
            reads[f"{reader}_reads_{writer}"] = r.returncode == 0
        info["cross_read"] = reads
    if models == "shared":
        if not info.get("cross_read", {}).get("current_reads_baseline", True):
            raise SystemExit("--models shared: the current tree cannot read the baseline's "
                             "model files; use --models own")
        own = {label: own["baseline"] for label in trees}
    info["models"] = models
    return Data(data_dir, data_dir / "stereo.yaml", tuple(scene_list), own), info


# ----------------------------------------------------------------------------- the benchmark

def _commands(kind: str, cli: list[str], data: Data, label: str,
              seed: int) -> tuple[list[str], int]:
    """The command of a CLI figure and its expected exit code."""
    if kind == "help":
        return [*cli, "--help"], 0
    s = data.scenes[0]
    scene = ["--stereo", str(data.stereo), "--right", s["right"], "--left", s["left"]]
    if kind == "error":
        return [*cli, "locate", "--model", str(data.root / "missing.npz"), *scene], 2
    if kind == "locate":
        return [*cli, "locate", "--model", data.models[label][s["garment"]], *scene, "--json",
                "--seed", str(seed)], 0
    raise ValueError(kind)


def _loadavg() -> list[float] | None:
    try:
        return [float(v) for v in Path("/proc/loadavg").read_text().split()[:3]]
    except OSError:
        return None


def _max_position_difference(a: Sequence[dict], b: Sequence[dict]) -> float | None:
    """Largest distance (mm) between the positions two trees found for the same scene."""
    first_a = {c["scene"]: c["position_mm"] for c in a}
    first_b = {c["scene"]: c["position_mm"] for c in b}
    common = sorted(set(first_a) & set(first_b))
    if not common:
        return None
    return float(max(np.linalg.norm(np.subtract(first_a[k], first_b[k])) for k in common))


def run_benchmark(trees: dict[str, Tree], data: Data, cli: list[str], kinds: Sequence[str],
                  repeats: int, calls: int, seed: int) -> dict[str, Any]:
    """The interleaved rounds; per tree and figure the samples (s) and what was found."""
    samples: dict[str, dict[str, list[float]]] = {
        label: {f: [] for f in FIGURES} for label in trees}
    cpu: dict[str, dict[str, list[float]]] = {label: {} for label in trees}
    found: dict[str, dict[str, Any]] = {label: {"cli": [], "calls": []} for label in trees}
    workers: dict[str, list[dict[str, Any]]] = {label: [] for label in trees}
    load_per_round = []
    fingerprints = []
    cwd = data.root.parent
    for r in range(-1, repeats):   # round -1: untimed, warms every cache
        order = round_order(max(r, 0))
        for kind in kinds:
            if kind == "inprocess":
                spec = {"stereo": str(data.stereo), "scenes": list(data.scenes),
                        "models": data.models, "seed": seed}
                got = in_process_round(trees, order, spec, calls if r >= 0 else 1, cwd)
                if r < 0:
                    continue
                for label, w in got.items():
                    samples[label]["prepare"].extend(w["prepare_s"])
                    samples[label]["first_pair"].append(w["first_pair"]["seconds"])
                    samples[label]["pair"].extend(c["seconds"] for c in w["calls"])
                    samples[label]["pair_cpu"].extend(c["cpu_seconds"] for c in w["calls"])
                    found[label]["calls"].extend(w["calls"])
                    workers[label].append({k: w[k] for k in ("numba_threads", "api")})
                continue
            for label in order:
                tree = trees[label]
                cmd, rc = _commands(kind, cli, data, label, seed)
                t = run_timed(cmd, tree_env(tree), cwd)
                _expect(t, rc, f"{label}: {kind}")
                if kind == "error" and "missing.npz" not in t.stderr:
                    raise RuntimeError(f"{label}: error path: stderr does not name the file: "
                                       f"{t.stderr.strip()[-500:]}")
                if r < 0:
                    continue
                samples[label][kind].append(t.wall_s)
                cpu[label].setdefault(kind, []).append(t.cpu_s)
                if kind == "locate":
                    res = json.loads(t.stdout)
                    samples[label]["locate_inner"].append(float(res["seconds"]))
                    found[label]["cli"].append({"scene": data.scenes[0]["name"],
                                                "found": res["found"], "score": res["score"],
                                                "position_mm": res["position_mm"]})
        if r < 0:
            _log("untimed round done")
            continue
        load_per_round.append(_loadavg())
        fingerprints.append(source_fingerprint(trees["current"].src))
        if len(fingerprints) > 1 and fingerprints[-1] != fingerprints[-2]:
            _log(f"warning: the current tree's sources changed during round {r + 1}")
        pair = {label: samples[label]["pair"][-1:] for label in trees}
        line = ", ".join(
            f"{k} {1e3 * samples['baseline'][k][-1]:.0f}/{1e3 * samples['current'][k][-1]:.0f}"
            for k in ("help", "error", "locate") if samples["current"][k])
        if pair["current"] and pair["baseline"]:
            line += (f", pair {1e3 * pair['baseline'][0]:.0f}/"
                     f"{1e3 * pair['current'][0]:.0f}")
        _log(f"round {r + 1}/{repeats} (baseline/current ms): {line}; "
             f"load {load_per_round[-1]}")
    return {"samples": samples, "cpu": cpu, "found": found, "workers": workers,
            "load_per_round": load_per_round, "fingerprint_per_round": fingerprints}


def figures(raw: dict[str, Any], seed: int) -> dict[str, Any]:
    """Per figure with samples: :func:`compare` of the baseline's and the current's."""
    out = {}
    for key in FIGURES:
        b, c = raw["samples"]["baseline"][key], raw["samples"]["current"][key]
        if not b or not c:
            continue
        fig = compare(b, c, seed, paired=len(b) == len(c),
                      tail=TAIL_FIGURES.get(key))
        fig["what"] = FIGURES[key]
        fig["samples"] = {"baseline": b, "current": c}
        cb, cc = raw["cpu"]["baseline"].get(key), raw["cpu"]["current"].get(key)
        if cb and cc:
            fig["cpu_seconds"] = {"baseline_median": float(np.median(cb)),
                                  "current_median": float(np.median(cc)),
                                  "ratio_of_medians": ratio(float(np.median(cc)),
                                                            float(np.median(cb)))}
        out[key] = fig
    return out


def render_table(result: dict[str, Any]) -> str:
    """A plain text table of the figures (milliseconds)."""

    def ms(v: float | None) -> str:
        return "-" if v is None else f"{1e3 * v:.1f}"

    def num(v: float | None, fmt: str = ".3f") -> str:
        return "-" if v is None else format(v, fmt)

    head = ("figure", "base med ms", "cur med ms", "base p99", "cur p99", "ratio", "paired",
            "90 % interval", f"<= {1 + TOLERANCE:.2f}")
    rows = [head]
    for fig in result["figures"].values():
        ci = fig["ratio_interval_90"]
        rows.append((fig["what"], ms(fig["baseline"]["median"]), ms(fig["current"]["median"]),
                     ms(fig["baseline"]["p99"]), ms(fig["current"]["p99"]),
                     num(fig["ratio_of_medians"]), num(fig["paired_ratio_median"]),
                     "-" if ci is None else f"{ci[0]:.3f}-{ci[1]:.3f}", fig["verdict"]))
        if "ratio_of_p99" in fig:
            ci = fig["ratio_of_p99_interval_90"]
            rows.append((f"{fig['what']} (p99)", "", "", "", "", num(fig["ratio_of_p99"]), "",
                         "-" if ci is None else f"{ci[0]:.3f}-{ci[1]:.3f}",
                         fig["verdict_p99"]))
    widths = [max(len(str(row[i])) for row in rows) for i in range(len(head))]
    lines = []
    for k, row in enumerate(rows):
        cells = [str(v).ljust(w) if i == 0 else str(v).rjust(w)
                 for i, (v, w) in enumerate(zip(row, widths, strict=True))]
        lines.append("  ".join(cells))
        if k == 0:
            lines.append("  ".join("-" * w for w in widths))
    base = result["baseline"]
    lines.append(f"baseline {base['rev']} ({(base['sha'] or 'working tree')[:12]}) vs current "
                 f"{result['current']['head'][:12]}"
                 f"{' + uncommitted edits' if result['current']['dirty_files'] else ''}; "
                 f"load {result['load']['before']} -> {result['load']['after']}")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline", default=DEFAULT_BASELINE,
                    help=f"git revision to compare with (default {DEFAULT_BASELINE}); "
                         f"{WORKTREE}: this working tree itself")
    ap.add_argument("--repeats", type=int, default=None, help="timed rounds (default 7)")
    ap.add_argument("--garments", default=None, help="comma-separated (default No.3,No.5)")
    ap.add_argument("--scenes", type=int, default=None, help="scenes per garment (default 3)")
    ap.add_argument("--calls", type=int, default=None,
                    help="in process: rounds over all scenes per worker (default 5)")
    ap.add_argument("--seed", type=int, default=1, help="simulation and search seed")
    ap.add_argument("--kinds", default=",".join(KINDS),
                    help=f"which measurements, comma-separated from {','.join(KINDS)}")
    ap.add_argument("--models", choices=("own", "shared"), default="own",
                    help="own: each tree locates with its own build's models; shared: both "
                         "with the baseline's")
    ap.add_argument("--worktree", type=Path, default=None,
                    help="where the baseline's worktree goes (default: the temp folder, "
                         "photomodel-bench-<commit>); an existing one at the revision is reused")
    ap.add_argument("--keep-worktree", action="store_true",
                    help="keep a worktree this run created (and its compiled kernels)")
    ap.add_argument("--keep-data", action="store_true", help="keep the simulated data")
    ap.add_argument("--no-warmup", action="store_true",
                    help="skip photomodel warmup (the kernels must be cached already)")
    ap.add_argument("--numba-threads", type=int, default=None,
                    help="NUMBA_NUM_THREADS of every subprocess (default: numba's, the CPUs)")
    ap.add_argument("--cli-via", choices=("script", "module"), default="script",
                    help="start the CLI as the photomodel script (default) or python -m")
    ap.add_argument("--quick", action="store_true",
                    help="smoke run: 2 rounds, one garment, one scene, 2 calls")
    ap.add_argument("--out", type=Path, default=Path("build/bench/startup.json"))
    args = ap.parse_args(argv)

    quick = {"repeats": 2, "garments": "No.3", "scenes": 1, "calls": 2}
    full = {"repeats": 7, "garments": "No.3,No.5", "scenes": 3, "calls": 5}
    for k, v in (quick if args.quick else full).items():
        if getattr(args, k) is None:
            setattr(args, k, v)
    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
    if not kinds or set(kinds) - set(KINDS):
        ap.error(f"--kinds: expected names from {', '.join(KINDS)}")
    if args.repeats < 1 or args.scenes < 1 or args.calls < 1:
        ap.error("--repeats, --scenes and --calls must be >= 1")
    garments = [g.strip() for g in args.garments.split(",") if g.strip()]
    if args.numba_threads is not None and args.numba_threads < 1:
        ap.error("--numba-threads must be >= 1")

    t_start = time.perf_counter()
    load_before = _loadavg()
    current = Tree("current", REPO / "src", None, None, args.numba_threads)
    head = _git("rev-parse", "HEAD")
    dirty = [ln[3:] for ln in _git("status", "--porcelain", "--", "src",
                                   strip=False).splitlines() if ln.strip()]
    fingerprint_before = source_fingerprint(current.src)
    worktree, created = None, False
    if args.baseline == WORKTREE:
        baseline = Tree("baseline", current.src, WORKTREE, None, args.numba_threads)
    else:
        sha = resolve_revision(args.baseline)
        worktree = args.worktree or Path(tempfile.gettempdir()) / f"photomodel-bench-{sha[:12]}"
        created = ensure_worktree(sha, worktree)
        _log(f"baseline {args.baseline} = {sha[:12]}: worktree {worktree}"
             f"{' (created)' if created else ' (reused)'}")
        baseline = Tree("baseline", worktree / "src", args.baseline, sha, args.numba_threads)
    trees = {"baseline": baseline, "current": current}
    cli = cli_prefix(args.cli_via)
    work = Path(tempfile.mkdtemp(prefix="bench-startup-"))
    try:
        probes = {label: probe(tree, work) for label, tree in trees.items()}
        warmup_s: dict[str, float | None] = {label: None for label in trees}
        if not args.no_warmup:
            for label, tree in trees.items():
                if label == "current" and tree.src == baseline.src:
                    continue
                _log(f"{label}: photomodel warmup --all (a cold cache compiles every kernel: "
                     f"1-2 min on two cores; cached: seconds) ...")
                t0 = time.perf_counter()
                proc = subprocess.run([*cli, "warmup", "--all"], env=tree_env(tree), cwd=work,
                                      stdout=sys.stderr, timeout=1800)
                if proc.returncode != 0:
                    raise SystemExit(f"{label}: photomodel warmup failed ({proc.returncode})")
                warmup_s[label] = time.perf_counter() - t0
                _log(f"{label}: warmup {warmup_s[label]:.1f} s")
        data, data_info = prepare_data(work, trees, cli, garments, args.scenes, args.seed,
                                       args.models, kinds)
        _log(f"{args.repeats} interleaved rounds of {', '.join(kinds)} "
             f"(one untimed round first) ...")
        raw = run_benchmark(trees, data, cli, kinds, args.repeats, args.calls, args.seed)
    finally:
        if args.keep_data:
            _log(f"data kept in {work}")
        else:
            shutil.rmtree(work, ignore_errors=True)
        if created and not args.keep_worktree and worktree is not None:
            remove_worktree(worktree)
    fingerprint_after = source_fingerprint(current.src)
    if fingerprint_after != fingerprint_before:
        _log("warning: the current tree's sources changed during the run")

    pos_cli = _max_position_difference(raw["found"]["baseline"]["cli"],
                                       raw["found"]["current"]["cli"])
    pos_calls = _max_position_difference(raw["found"]["baseline"]["calls"],
                                         raw["found"]["current"]["calls"])
    result = {
        "meta": metadata("startup", args.seed),
        "baseline": {"rev": args.baseline, "sha": baseline.sha, "src": str(baseline.src),
                     "worktree": str(worktree) if worktree else None,
                     "worktree_created": created, "photomodel_file": probes["baseline"]["file"]},
        "current": {"head": head, "src": str(current.src), "dirty_files": dirty,
                    "source_fingerprint_before": fingerprint_before,
                    "source_fingerprint_after": fingerprint_after,
                    "sources_changed_during_run": fingerprint_after != fingerprint_before,
                    "source_fingerprint_per_round": raw["fingerprint_per_round"],
                    "photomodel_file": probes["current"]["file"]},
        "settings": {"repeats": args.repeats, "garments": garments, "scenes": args.scenes,
                     "calls": args.calls, "kinds": kinds, "quick": args.quick,
                     "tolerance": TOLERANCE, "cli": cli, "python": sys.executable,
                     "NUMBA_CACHE_DIR": os.environ.get("NUMBA_CACHE_DIR"),
                     "NUMBA_NUM_THREADS": (str(args.numba_threads) if args.numba_threads
                                           else os.environ.get("NUMBA_NUM_THREADS")),
                     "interleaving": "per round and figure, the baseline first in even rounds",
                     "warmup_seconds": warmup_s},
        "data": {**data_info, "scenes": [s["name"] for s in data.scenes],
                 "cli_scene": data.scenes[0]["name"] if data.scenes else None},
        "load": {"before": load_before, "after": _loadavg(), "per_round": raw["load_per_round"],
                 "cpus": os.cpu_count()},
        "figures": figures(raw, args.seed),
        "results": {"found": raw["found"],
                    "cli_position_difference_max_mm": pos_cli,
                    "in_process_position_difference_max_mm": pos_calls},
        "workers": raw["workers"],
        "wall_seconds": time.perf_counter() - t_start,
    }
    misses = [k for k, f in result["figures"].items() if f["verdict"] == "fail"]
    result["summary"] = {"misses": misses, "all_pass": not misses}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=1) + "\n")
    print(render_table(result))
    _log(f"wrote {args.out} ({result['wall_seconds']:.0f} s)")
    return result


if __name__ == "__main__":
    main()
