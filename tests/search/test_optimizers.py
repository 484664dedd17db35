"""The real-valued optimisers (RealGA, CMAES, DifferentialEvolution) behind ask/tell."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from photomodel.locate import make_optimizer
from photomodel.search import (
    CMAES,
    OPTIMIZERS,
    CMAConfig,
    DEConfig,
    DifferentialEvolution,
    Optimizer,
    RealGA,
    RealGAConfig,
    SearchResult,
    SearchSpace,
    run_search,
)

SPACE = SearchSpace.from_ranges()
NAMES = ("rga", "cma", "de")
FAST = {"rga": RealGAConfig(max_generations=200), "cma": CMAConfig(restarts=1),
        "de": DEConfig()}
"""Settings that keep a full run short (CMA-ES: one restart instead of four)."""
Fitness = Callable[[np.ndarray], np.ndarray]


def unit(x: np.ndarray) -> np.ndarray:
    """Normalised coordinates of pose vectors (..., 6) in SPACE, computed here afresh."""
    return (x - SPACE.lower) / (SPACE.upper - SPACE.lower)


PEAK_U = np.array([0.3, 0.7, 0.55, 0.4, 0.62, 0.25])
PEAK = SPACE.lower + (SPACE.upper - SPACE.lower) * PEAK_U


def bowl(x: np.ndarray) -> np.ndarray:
    """Negative squared normalised distance to PEAK: maximum 0 there."""
    return -np.sum((unit(x) - PEAK_U) ** 2, axis=-1)


def make(name: str, config: object = None, rng: int = 0, **kwargs: object) -> Optimizer:
    cls = {"rga": RealGA, "cma": CMAES, "de": DifferentialEvolution}[name]
    return cls(SPACE, config, rng=rng, **kwargs)  # type: ignore[arg-type]


def first_run_and_final(opt: RealGA | CMAES, fitness: Fitness) -> tuple[float, SearchResult]:
    """Best fitness of the first run (before any restart) and the final result."""
    restarts: list[int] = []

    def record(_: Optimizer) -> None:
        restarts.append(opt.restarts_done)

    res = run_search(opt, fitness, callback=record)
    end = restarts.index(1) if 1 in restarts else len(restarts) - 1
    return float(res.best_history[end]), res


# (a) a smooth function: the maximum, to a tight tolerance, in a bounded budget.
@pytest.mark.parametrize(("name", "config", "max_evals", "tol_u"), [
    ("rga", RealGAConfig(max_generations=150), 9_000, 2e-3),
    ("cma", CMAConfig(restarts=0), 2_000, 1e-4),
    ("de", DEConfig(), 10_000, 2e-4),
])
def test_maximises_a_smooth_function(name: str, config: object, max_evals: int,
                                     tol_u: float) -> None:
    for seed in (0, 1):
        res = run_search(make(name, config, rng=seed), bowl)
        assert res.evaluations <= max_evals
        assert np.max(np.abs(unit(res.x) - PEAK_U)) < tol_u, (seed, res.x)
        assert res.fitness == pytest.approx(float(bowl(res.x)))
        assert np.all(np.diff(res.best_history) >= 0)
        assert len(res.best_history) == len(res.mean_history) == res.iterations


# (b) multimodal functions on which plain runs get stuck and restarts help.
RASTRIGIN_U = np.array([0.62, 0.41, 0.5, 0.45, 0.55, 0.6])


def rastrigin(x: np.ndarray) -> np.ndarray:
    """A bowl with a grid of local maxima in x and y (like a plaid's repeats); max 0."""
    z = 8 * (unit(x) - RASTRIGIN_U)
    return -np.sum(z**2, axis=-1) - 5 * np.sum(1 - np.cos(2 * np.pi * z[..., :2]), axis=-1)


def two_peaks(x: np.ndarray) -> np.ndarray:
    """A broad local peak (0.8) and a narrow global one (about 1.05) in x-y, a bowl elsewhere."""
    u = unit(x)
    broad = 0.8 * np.exp(-0.5 * np.sum((u[..., :2] - [0.25, 0.3]) ** 2, axis=-1) / 0.3**2)
    narrow = np.exp(-0.5 * np.sum((u[..., :2] - [0.8, 0.75]) ** 2, axis=-1) / 0.06**2)
    rest = np.exp(-0.5 * np.sum((u[..., 2:] - [0.5, 0.5, 0.5, 0.4]) ** 2, axis=-1) / 0.3**2)
    return (broad + narrow) * rest


def test_cma_ipop_restarts_escape_local_maxima() -> None:
    # Seeds on which the first run (popsize 9) ends on a local maximum; the restarts
    # (popsize 18, 36) find the global one.
    for seed in (0, 5):
        first, res = first_run_and_final(CMAES(SPACE, CMAConfig(restarts=2), rng=seed),
                                         rastrigin)
        assert first < -0.5, seed
        assert res.fitness > -0.01, seed
        assert "after 2 restarts" in res.stop_reason


def test_real_ga_restarts_find_a_narrow_peak() -> None:
    cfg = RealGAConfig(patience=20, max_generations=400)
    outcomes = [first_run_and_final(RealGA(SPACE, cfg, rng=s), two_peaks) for s in range(6)]
    found_first = sum(first > 0.99 for first, _ in outcomes)
    found_final = sum(res.fitness > 0.99 for _, res in outcomes)
    assert found_first <= 1
    assert found_final >= found_first + 3


# (c) every asked point lies in the box, also when the maximum is in a corner.
@pytest.mark.parametrize("name", NAMES)
def test_asked_points_lie_in_the_box(name: str) -> None:
    def corner(x: np.ndarray) -> np.ndarray:
        return np.sum(unit(x), axis=-1)  # maximum at the upper corner

    for opt in (make(name, rng=3),
                make(name, rng=4, x0=SPACE.upper, sigma0=SPACE.upper - SPACE.lower)):
        for _ in range(30):
            x = opt.ask()
            assert x.ndim == 2 and x.shape[1] == 6
            assert np.all(SPACE.contains(x))
            opt.tell(x, corner(x))


# (d) the same seed repeats the search, another seed does not.
def _trace(opt: Optimizer, n: int = 6) -> list[np.ndarray]:
    out = []
    for _ in range(n):
        x = opt.ask()
        out.append(x)
        opt.tell(x, bowl(x))
    return out


@pytest.mark.parametrize("name", NAMES)
def test_seeded(name: str) -> None:
    a, b, c = (_trace(make(name, rng=s)) for s in (11, 11, 12))
    for xa, xb in zip(a, b, strict=True):
        np.testing.assert_array_equal(xa, xb)
    assert not np.array_equal(a[0], c[0])
    assert not np.array_equal(a[-1], c[-1])


def test_cma_leaves_numpy_global_random_state_alone() -> None:
    # cma's own `seed` option would reseed np.random; interleaved runs must still repeat.
    # The legacy global state is what is checked here, hence NPY002.
    before = np.random.get_state()[1].copy()  # noqa: NPY002
    one, two = make("cma", rng=5), make("cma", rng=5)
    interleaved = [(_trace(one, 1)[0], _trace(two, 1)[0]) for _ in range(4)]
    np.testing.assert_array_equal(np.random.get_state()[1], before)  # noqa: NPY002
    for xa, xb in interleaved:
        np.testing.assert_array_equal(xa, xb)


# (e) stop reasons, evaluation counts.
def flat(x: np.ndarray) -> np.ndarray:
    return np.zeros(len(x))


@pytest.mark.parametrize(("name", "config", "fitness", "expect"), [
    ("rga", RealGAConfig(max_generations=7), bowl, "max_generations (7)"),
    ("rga", RealGAConfig(patience=3, restarts=1), flat, "no improvement for 3 generations"),
    ("cma", CMAConfig(maxfevals=200), bowl, "maxfevals (200)"),
    ("cma", CMAConfig(restarts=1, tolfun=1e-3), bowl,
     "cma tolfun: fitness range below tolfun (0.001) after 1 restart"),
    ("cma", CMAConfig(restarts=0), flat, "cma tolfun: fitness range below tolfun (1e-08)"),
    ("de", DEConfig(max_generations=5), bowl, "max_generations (5)"),
    ("de", DEConfig(tol=1e-3), bowl, "population fitness spread"),
])
def test_stop_reasons_and_evaluation_counts(name: str, config: object, fitness: Fitness,
                                            expect: str) -> None:
    opt = make(name, config, rng=2)
    told = 0
    while opt.stop() is None:
        assert opt.result.stop_reason == "running"
        x = opt.ask()
        f = fitness(x)
        opt.tell(x, f)
        told += len(f)
    res = opt.result
    assert isinstance(res.stop_reason, str) and res.stop_reason.startswith(expect)
    assert res.stop_reason == opt.stop()
    assert res.evaluations == told
    assert res.iterations == len(res.best_history)


# (f) a start pose: the first population lies around it.
@pytest.mark.parametrize("name", NAMES)
def test_starts_around_x0(name: str) -> None:
    x0 = np.array([-120.0, 80.0, 610.0, 0.02, -0.03, -0.3])
    sigma0 = np.array([5.0, 5.0, 10.0, 0.005, 0.005, 0.01])
    x = make(name, rng=6, x0=x0, sigma0=sigma0).ask()
    assert np.all(np.abs(x - x0) < 5 * sigma0)
    assert np.all(np.abs(x.mean(axis=0) - x0) < sigma0)
    if name != "cma":
        np.testing.assert_allclose(x[0], x0)
    res = run_search(make(name, FAST[name], rng=6, x0=x0, sigma0=sigma0), bowl)
    assert np.max(np.abs(unit(res.x) - PEAK_U)) < 0.05  # and still finds the far peak


@pytest.mark.parametrize("name", NAMES)
def test_rejects_bad_start(name: str) -> None:
    with pytest.raises(ValueError, match="x0"):
        make(name, x0=np.zeros(5))
    with pytest.raises(ValueError, match="sigma0"):
        make(name, x0=PEAK, sigma0=-np.ones(6))
    with pytest.raises(ValueError, match="sigma0"):
        make(name, sigma0=np.ones(6))


# (g) non-finite fitness is the worst.
@pytest.mark.parametrize("name", NAMES)
def test_non_finite_fitness_is_worst(name: str) -> None:
    def poisoned(x: np.ndarray) -> np.ndarray:
        f = bowl(x)
        u = unit(x)
        f[u[:, 0] > 0.6] = np.nan
        f[u[:, 1] < 0.4] = np.inf  # +inf too: not a winner
        return f

    opt = make(name, FAST[name], rng=8)
    x = opt.ask()
    opt.tell(x, np.full(len(x), np.nan))  # a batch without one finite value
    res = run_search(opt, poisoned)
    assert np.isfinite(res.fitness)
    assert np.max(np.abs(unit(res.x) - PEAK_U)) < 0.01


def test_configs_validate() -> None:
    with pytest.raises(ValueError, match="elite"):
        RealGAConfig(elite=60)
    with pytest.raises(ValueError, match="min_step"):
        RealGAConfig(mutation_step=1e-7)
    with pytest.raises(ValueError, match="sigma0"):
        CMAConfig(sigma0=2.0)
    with pytest.raises(ValueError, match="population"):
        DEConfig(population=3)
    with pytest.raises(ValueError, match="CR"):
        DEConfig(CR=1.5)


def test_registered_by_name() -> None:
    for name, cls in (("rga", RealGA), ("cma", CMAES), ("de", DifferentialEvolution)):
        assert OPTIMIZERS[name] is cls
        assert isinstance(make_optimizer(name, SPACE, rng=0), cls)  # type: ignore[arg-type]


def test_cma_is_imported_only_when_a_strategy_is_built() -> None:
    """``import photomodel.search`` leaves the optional ``cma`` package unloaded."""
    import subprocess
    import sys

    code = ("import sys, photomodel.search, photomodel.locate; "
            "sys.exit('cma' in sys.modules)")
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0


def test_cma_es_without_cma_names_the_option_and_the_extra(monkeypatch: pytest.MonkeyPatch
                                                          ) -> None:
    import sys

    from photomodel.errors import InputError

    monkeypatch.setitem(sys.modules, "cma", None)     # import cma raises ImportError
    for build in (lambda: CMAES(SPACE, rng=0), lambda: make_optimizer("cma", SPACE, rng=0)):
        with pytest.raises(InputError, match=r"^--optimizer cma: .*pip install "
                                             r"'photomodel\[compare\]'"):
            build()
