"""``warmup``: compile every numba kernel that ``locate`` and ``identify`` use into the cache.

The kernels compile on their first call and numba caches them (:mod:`photomodel._jit`); a
fresh install's first ``locate`` would compile them one after the other. :func:`warmup`
compiles them as an explicit step: groups of kernels on parallel processes (spawned, as many
as CPUs, each taking the next group when it is free), each group driving one stage of the
pipeline on a small synthetic stereo pair (a striped garment drawn with numpy and OpenCV):

1. ``image features`` (which makes the pair's features that later groups take) beside
   ``small kernels`` (pose conversions, Gauss-Newton's step arithmetic);
2. the others, longest first; the ``Gauss-Newton loop`` after ``normal equations`` and
   ``soft fitness``, whose kernels its loop calls and then loads from the cache;
3. ``check``: one ``locate`` and one ``identify`` of the synthetic pair, which compiles
   whatever the groups missed and counts it.

A probe runs the check first without compiling: when everything is cached, that is all.
Saves to the cache are locked (:mod:`photomodel._jit`): processes that compile a shared
callee at once leave one complete entry.
"""

from __future__ import annotations

import concurrent.futures
import functools
import multiprocessing
import os
import queue
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from photomodel.camera import PinholeCamera, StereoRig
    from photomodel.fitness import SoftFitness, StereoFeatures
    from photomodel.model import PhotoModel
    from photomodel.search import SearchSpace

__all__ = ["GROUPS", "SIMULATOR_GROUP", "GroupReport", "Scene", "WarmupReport", "all_cached",
           "load_kernels", "make_scene", "warmup"]


@dataclass(frozen=True)
class GroupReport:
    """One group's run: its name, wall and CPU seconds in its process and the functions it
    compiled (not loaded from the cache), by qualified name."""

    name: str
    seconds: float
    cpu_seconds: float
    functions: tuple[str, ...]

    @property
    def compiled(self) -> int:
        """How many functions it compiled."""
        return len(self.functions)


@dataclass(frozen=True)
class WarmupReport:
    """What :func:`warmup` did.

    Attributes
    ----------
    seconds : float
        Wall time of the whole warmup.
    groups : tuple of GroupReport
        The groups run, in the order they finished (the ``check`` last); only the check
        when everything was cached already.
    cache : str
        Where the kernels are cached (:meth:`photomodel._jit.CacheChoice.describe`).
    workers : int
        Processes used.
    """

    seconds: float
    groups: tuple[GroupReport, ...]
    cache: str
    workers: int

    @property
    def compiled(self) -> int:
        """Functions compiled by every group together."""
        return sum(g.compiled for g in self.groups)

    @property
    def was_cached(self) -> bool:
        """Whether everything was in the cache already (nothing compiled)."""
        return self.compiled == 0


# --- the synthetic stereo pair ------------------------------------------------------------

_STRIPES_BGR = ((40, 40, 200), (200, 90, 40), (40, 200, 220), (200, 60, 170))
"""The garment's stripes (red, blue, yellow, violet) on the green model plane."""
_GREEN_BGR = (50, 150, 50)
_TABLE_BGR = (120, 125, 135)


@dataclass(frozen=True)
class Scene:
    """A synthetic model and stereo pair (images (480, 640, 3) BGR): what the groups run
    the pipeline on; ``features`` once the ``image features`` group made them."""

    rig: StereoRig
    model: PhotoModel
    right: NDArray[np.uint8]
    left: NDArray[np.uint8]
    features: StereoFeatures | None = None


def _rotation(axis: int, angle: float) -> NDArray[np.float64]:
    c, s = np.cos(angle), np.sin(angle)
    i, j = [k for k in range(3) if k != axis]
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def _draw(camera: PinholeCamera, R: NDArray[np.float64], t: NDArray[np.float64],
          background: tuple[int, int, int]) -> NDArray[np.uint8]:
    """The garment (240 x 180 mm, four stripes across x) on the plane at pose ``(R, t)``
    through ``camera``, on a flat ``background``."""
    import cv2

    image = np.empty((camera.height_px, camera.width_px, 3), dtype=np.uint8)
    image[:] = background
    edges = np.linspace(-120.0, 120.0, len(_STRIPES_BGR) + 1)
    for k, colour in enumerate(_STRIPES_BGR):
        x0, x1 = edges[k], edges[k + 1]
        side = np.linspace(0.0, 1.0, 12)
        outline = np.concatenate([
            np.column_stack([x0 + (x1 - x0) * side, np.full(12, -90.0)]),
            np.column_stack([np.full(12, x1), -90.0 + 180.0 * side]),
            np.column_stack([x1 - (x1 - x0) * side, np.full(12, 90.0)]),
            np.column_stack([np.full(12, x0), 90.0 - 180.0 * side])])
        points = np.column_stack([outline, np.zeros(len(outline))]) @ R.T + t
        uv = np.round(camera.project(points)).astype(np.int32)
        cv2.fillPoly(image, [uv.reshape(-1, 1, 2)], colour)
    return image


def make_scene() -> Scene:
    """The synthetic garment's photo-model and a stereo pair of it at about 680 mm."""
    from photomodel.camera import PinholeCamera, StereoRig
    from photomodel.model import DEFAULT_STATION_DISTANCE_MM, build_photo_model

    def camera(f: float, dist: list[float]) -> PinholeCamera:
        K = np.array([[f, 0.0, 320.5], [0.0, f, 240.5], [0.0, 0.0, 1.0]])
        return PinholeCamera(K, np.array(dist), 640, 480)

    station = camera(760.0, [-0.12, 0.08, 0.0005, -0.0004, 0.0])
    photo = _draw(station, np.eye(3), np.array([0.0, 0.0, DEFAULT_STATION_DISTANCE_MM]),
                  _GREEN_BGR)
    background = np.empty_like(photo)
    background[:] = _GREEN_BGR
    model = build_photo_model(photo, background, station, DEFAULT_STATION_DISTANCE_MM,
                              name="warmup").model
    cam1 = camera(800.0, [-0.15, 0.06, 0.0011, -0.0008, 0.0])
    cam2 = camera(800.0, [-0.145, 0.058, -0.0009, 0.0012, 0.0])
    R21 = _rotation(1, np.deg2rad(10.0))
    rig = StereoRig(cam1, cam2, R21, np.array([-120.0, 0.0, 12.0]))
    R = _rotation(2, np.deg2rad(20.0)) @ _rotation(0, np.deg2rad(3.0))
    t = np.array([25.0, -15.0, 680.0])
    right = _draw(cam1, R, t, _TABLE_BGR)
    left = _draw(cam2, R21 @ R, R21 @ t + rig.T, _TABLE_BGR)
    return Scene(rig, model, right, left)


# --- the groups ---------------------------------------------------------------------------

def _space(scene: Scene) -> SearchSpace:
    from photomodel.search import SearchSpace
    return SearchSpace.from_ranges(R_cam1_plane=scene.rig.R_cam1_facing)


def _pose(scene: Scene) -> NDArray[np.float64]:
    """A pose vector (6,) near the garment."""
    return np.array([25.0, -15.0, 680.0, 0.02, -0.01, np.sin(np.deg2rad(10.0))])


def _fitness(scene: Scene, level: int = 0, **kwargs: Any) -> SoftFitness:
    from photomodel.fitness import SoftFitness
    return SoftFitness(scene.model, scene.features, level, **kwargs)


def _image_features(scene: Scene) -> Scene:
    from photomodel.fitness import StereoFeatures

    features = StereoFeatures(scene.rig, scene.right, scene.left)
    return Scene(scene.rig, scene.model, scene.right, scene.left, features)


def _helpers(scene: Scene) -> None:
    """The small kernels that need no features: pose conversions, plain log-opponent
    features (the model photo's) and Gauss-Newton's step arithmetic, with the types its
    loop passes them."""
    from photomodel.geometry import (
        facing_pose_vectors,
        pose_vectors_to_matrices,
        rotation_from_eps,
        strained_matrices,
    )
    from photomodel.image._features import log_opponent
    from photomodel.search._gauss_newton_loop import (
        add_prior,
        clip_genes,
        damped_step,
        extrapolation,
        map_derivatives,
        prior_values,
        slope_along,
    )

    log_opponent(scene.right)
    x = _pose(scene)
    pose_vectors_to_matrices(x[None])
    strained_matrices(x[None], np.zeros(3))
    facing_pose_vectors(x[None], np.array([1.0, 0.0, 0.0, 0.0]))
    rotation_from_eps(x[3:])
    box = np.full(6, 1e3)
    for genes in (6, 9):
        v = np.zeros(genes)
        v[:6] = x
        free = np.ones(genes, dtype=np.bool_)
        gradient = np.ones(genes)
        metric = np.eye(genes)
        prior = np.eye(genes)
        map_derivatives(v, free)
        add_prior(gradient, metric, prior, v, free)
        damped_step(metric, 0.1, gradient)
        slope_along(gradient, v, free)
        clip_genes(v, -box, box, 0.1)
        prior_values(v[None], prior)
    extrapolation(1.0, 2.0, 0.5, 4.0)


def _soft_fitness(scene: Scene) -> None:
    from photomodel.geometry import pose_vectors_to_matrices

    x = np.vstack([_pose(scene)] * 3)
    fitness = _fitness(scene)
    fitness(x)
    others = [_fitness(scene, optics_blur_mm=b) for b in (0.0, 1.0)]
    fitness.evaluate_colourings(others, pose_vectors_to_matrices(x[:1])[0])


def _normal_equations(scene: Scene) -> None:
    from photomodel.geometry import pose_vectors_to_matrices

    fitness = _fitness(scene, 1)
    A = pose_vectors_to_matrices(_pose(scene)[None])[0]
    dA = np.zeros((6, 4, 4))
    for with_offsets in (False, True):
        fitness.normal_equations(A, dA, np.zeros((2, 3)), with_offsets)


def _score(scene: Scene) -> None:
    from photomodel.fitness import score_terms
    from photomodel.geometry import pose_vectors_to_matrices

    score_terms(_fitness(scene), pose_vectors_to_matrices(_pose(scene)[None])[0])


def _scans(scene: Scene) -> None:
    from photomodel.fitness import ScanConfig, relight_scan, scan_flat_poses
    from photomodel.locate import prepare_model
    from photomodel.locate._locate import COARSE_SCAN

    space = _space(scene)
    prepare_model(scene.model, scene.features, space=space, scans=(COARSE_SCAN, ScanConfig()))
    for config in (ScanConfig(), COARSE_SCAN):
        scan_flat_poses(scene.model, scene.features, space.lower, space.upper, config)
        relight_scan(scene.model, scene.features, space.lower, space.upper, config)


def _local_search(scene: Scene) -> None:
    from photomodel.search import RefineConfig
    from photomodel.search._kernel_loops import OnPlane, refine_kernel

    space = _space(scene)
    rng = np.random.default_rng(0)
    fitness = _fitness(scene, 2)
    config = RefineConfig(max_iterations=2)
    refine_kernel(fitness, space, _pose(scene), config, rng)
    on_plane = OnPlane(fitness, space, np.array([1.0, 0.0, 0.0, 0.0]))
    refine_kernel(on_plane, space, _pose(scene), config, rng)


def _gauss_newton_loop(scene: Scene) -> None:
    from photomodel.search import gauss_newton_refine

    space = _space(scene)
    fitness = _fitness(scene, 1)
    gauss_newton_refine(fitness, _pose(scene), space, 1)
    gauss_newton_refine(fitness, _pose(scene), space, 0, strain=np.zeros(3))


def _check(scene: Scene) -> None:
    from photomodel.identify import identify
    from photomodel.locate import locate

    locate(scene.model, scene.rig, scene.right, scene.left, rng=0)
    identify([scene.model], scene.rig, scene.right, scene.left, rng=0)


def _simulator(scene: Scene) -> None:
    import tempfile

    from photomodel.sim import write_dataset

    with tempfile.TemporaryDirectory(prefix="photomodel-warmup-") as out:
        write_dataset(out, ["No.1"], ("paper", "wrinkles"), scenes=1, seed=0, overwrite=True)


Group = tuple[str, Callable[[Scene], Any], tuple[str, ...]]
"""A group: its name, what it runs on the scene, the groups it waits for."""

GROUPS: tuple[Group, ...] = (
    ("image features", _image_features, ()),
    ("small kernels", _helpers, ()),
    ("normal equations", _normal_equations, ("image features",)),
    ("soft fitness", _soft_fitness, ("image features",)),
    ("Gauss-Newton loop", _gauss_newton_loop,
     ("normal equations", "soft fitness", "small kernels")),
    ("score", _score, ("image features",)),
    ("scans", _scans, ("image features",)),
    ("local search", _local_search, ("soft fitness",)),
)
"""The groups: name, what it runs on the scene, and the groups it waits for (the first makes
the features the others take; the loops call the kernels of the groups they wait for, and
load them from the cache). A free process takes the first group whose waits are over."""

SIMULATOR_GROUP = ("simulator", _simulator, ())
"""The simulator's kernels (``warmup(simulator=True)``), beside the other groups."""

_CHECK = ("check", _check, tuple(name for name, _, _ in GROUPS))


# --- running them -------------------------------------------------------------------------

class _CompileCounter:
    """Records numba's compilations (not cache loads) of functions outside numba itself; with
    ``abort``, raises :class:`_NotCached` at the first one instead."""

    def __init__(self, abort: bool = False) -> None:
        from numba.core import event

        counter = self

        class Listener(event.Listener):  # type: ignore[misc]
            def on_start(self, ev: Any) -> None:
                dispatcher = ev.data["dispatcher"]
                module = getattr(dispatcher.py_func, "__module__", None) or ""
                if not module.startswith("numba"):
                    name = f"{module}.{dispatcher.py_func.__qualname__}"
                    counter.functions.append(name)
                    if abort:
                        raise _NotCached(name)

            def on_end(self, ev: Any) -> None:
                pass

        self.functions: list[str] = []
        self._listener = Listener()
        self._event = event

    def __enter__(self) -> _CompileCounter:
        self._event.register("numba:compile", self._listener)
        return self

    def __exit__(self, *exc: object) -> None:
        self._event.unregister("numba:compile", self._listener)


class _NotCached(Exception):
    """A kernel had to compile (raised by the cached-everything probe)."""


_messages: Any = None


def _init_worker(messages: Any) -> None:
    global _messages
    _messages = messages
    import photomodel.fitness  # noqa: F401  # the imports overlap the first group
    import photomodel.search  # noqa: F401


def _run_group(name: str, run: Callable[[Scene], Any], scene: Scene | None
               ) -> tuple[GroupReport, Scene | None]:
    """Run the group ``name`` (``run`` on ``scene``, made here when None) in this process:
    its report and, for the first group, the scene with its features."""
    if _messages is not None:
        _messages.put(name)
    t0 = time.perf_counter()
    cpu0 = time.process_time()
    scene = scene if scene is not None else make_scene()
    with _CompileCounter() as counter:
        out = run(scene)
    report = GroupReport(name, time.perf_counter() - t0, time.process_time() - cpu0,
                         tuple(counter.functions))
    return report, out if isinstance(out, Scene) else None


def _probe(simulator: bool) -> bool:
    """Whether the check (and with ``simulator`` the simulator's group) runs without
    compiling anything."""
    try:
        with _CompileCounter(abort=True):
            scene = _image_features(make_scene())
            _helpers(scene)
            _check(scene)
            if simulator:
                _simulator(scene)
    except _NotCached:
        return False
    return True


def all_cached() -> bool:
    """Whether every kernel ``locate`` and ``identify`` use loads from the cache: the check
    run in this process, stopped at the first compilation (no process is started)."""
    return _probe(False)


def load_kernels() -> None:
    """Load every kernel ``locate`` and ``identify`` use into this process (compiling any
    that is not cached): one locate and one identify of the synthetic scene. A resident
    service calls it after :func:`warmup`, so that its first request loads nothing."""
    scene = _image_features(make_scene())
    _helpers(scene)
    _check(scene)


def _cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:    # not on Linux
        return os.cpu_count() or 1


def warmup(progress: Callable[[str], None] | None = None, *, workers: int | None = None,
           simulator: bool = False) -> WarmupReport:
    """Compile every numba kernel that ``locate`` and ``identify`` use into the cache.

    Parameters
    ----------
    progress : callable, optional
        Called with one line as each group starts and ends (``warmup: compiling soft
        fitness (3/8) ...``).
    workers : int, optional
        Processes side by side (default: the CPUs this process may use).
    simulator : bool
        Also compile the simulator's kernels (``photomodel simulate``, ``demo``).

    Returns
    -------
    WarmupReport
    """
    from photomodel._jit import CACHE

    groups = [*GROUPS, SIMULATOR_GROUP] if simulator else list(GROUPS)
    return _run(groups, _CHECK, functools.partial(_probe, simulator), progress,
                max(1, workers or _cpus()), CACHE.describe())


def _run(groups: list[Group], check: Group, probe: Callable[[], bool],
         progress: Callable[[str], None] | None, workers: int, cache: str) -> WarmupReport:
    """:func:`warmup` of ``groups`` (name, what it runs, the groups it waits for) and then
    ``check``, on ``workers`` spawned processes, unless ``probe`` (run beside the first
    groups) finds everything cached."""
    say = progress or (lambda line: None)
    t0 = time.perf_counter()
    context = multiprocessing.get_context("spawn")
    messages = context.Queue()
    groups = [*groups, check]
    order = [name for name, _, _ in groups]
    runs = {name: run for name, run, _ in groups}
    waits = {name: set(after) for name, _, after in groups}
    say(f"warmup: kernels cached in {cache}")
    reports: list[GroupReport] = []
    with concurrent.futures.ProcessPoolExecutor(workers, mp_context=context,
                                                initializer=_init_worker,
                                                initargs=(messages,)) as pool:
        done: set[str] = set()
        scene: Scene | None = None
        running: dict[concurrent.futures.Future[Any], str] = {}

        def start_ready() -> None:
            """A free process takes the first group whose waits are over."""
            for name in order:
                if len(running) >= workers:
                    return
                if name not in done and name not in running.values() and waits[name] <= done:
                    running[pool.submit(_run_group, name, runs[name], scene)] = name

        # The probe and the first groups start together: on a cold cache the probe stops at
        # its first compilation, and the groups are under way by then.
        probed = pool.submit(probe)
        start_ready()
        if probed.result():
            concurrent.futures.wait(running)
            _drain(messages, order, None)
            seconds = time.perf_counter() - t0
            say(f"warmup: every kernel was cached already ({seconds:.1f} s)")
            return WarmupReport(seconds, (GroupReport(check[0], seconds, 0.0, ()),), cache,
                                workers)
        while running:
            finished, _ = concurrent.futures.wait(
                running, timeout=0.2, return_when=concurrent.futures.FIRST_COMPLETED)
            _drain(messages, order, say)
            for future in finished:
                name = running.pop(future)
                group, made = future.result()
                scene = made or scene
                done.add(name)
                reports.append(group)
                say(f"warmup: {name} done: {group.compiled} functions compiled in "
                    f"{group.seconds:.1f} s")
            start_ready()
    seconds = time.perf_counter() - t0
    report = WarmupReport(seconds, tuple(reports), cache, workers)
    say(f"warmup: done in {seconds:.1f} s ({report.compiled} functions compiled)")
    return report


def _drain(messages: Any, order: list[str], say: Callable[[str], None] | None) -> None:
    """Report the groups that started since the last call (None: forget them)."""
    while True:
        try:
            name = messages.get_nowait()
        except queue.Empty:
            return
        if say is not None:
            say(f"warmup: compiling {name} ({order.index(name) + 1}/{len(order)}) ...")
