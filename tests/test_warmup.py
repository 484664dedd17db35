"""``photomodel warmup``: its groups on a process pool (order, waits, progress, the cached
shortcut), the CLI's wiring, and (slow) a full warmup from an empty cache after which
``locate`` and ``identify`` compile nothing."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from photomodel import _warmup
from photomodel._jit import CacheChoice, njit
from photomodel.cli._main import main


@njit
def _twice(x):  # pragma: no cover - compiled
    return 2.0 * x


def _compiles(scene: _warmup.Scene) -> None:
    _twice(1.0)


def _nothing(scene: _warmup.Scene) -> None:
    return None


def _not_cached() -> bool:
    return False


def _cached() -> bool:
    return True


_GROUPS: list[_warmup.Group] = [
    ("first", _compiles, ()),
    ("second", _nothing, ("first",)),
    ("third", _nothing, ("first",)),
]
_CHECK: _warmup.Group = ("check", _nothing, ("first", "second", "third"))


def test_groups_run_after_what_they_wait_for_with_progress() -> None:
    lines: list[str] = []
    report = _warmup._run(_GROUPS, _CHECK, _not_cached, lines.append, 2, "here")
    assert lines[0] == "warmup: kernels cached in here"
    assert lines[-1].startswith("warmup: done in ")

    def at(line: str) -> int:
        return next(i for i, text in enumerate(lines) if text.startswith(line))

    assert at("warmup: compiling first (1/4) ...") < at("warmup: first done: ")
    for name, number in (("second", 2), ("third", 3)):
        assert at("warmup: first done: ") < at(f"warmup: compiling {name} ({number}/4) ...")
    assert at("warmup: compiling check (4/4) ...") > max(
        at("warmup: second done: "), at("warmup: third done: "))
    assert [g.name for g in report.groups][-1] == "check"
    assert {g.name for g in report.groups} == {"first", "second", "third", "check"}
    assert report.workers == 2 and report.cache == "here"
    assert all(g.seconds >= 0 and g.cpu_seconds >= 0 for g in report.groups)
    # the first group's kernel compiled, unless an earlier run cached it
    assert set(report.groups[0].functions) <= {f"{__name__}._twice"}


def test_everything_cached_stops_after_the_probe() -> None:
    lines: list[str] = []
    report = _warmup._run(_GROUPS, _CHECK, _cached, lines.append, 2, "here")
    assert report.was_cached and report.compiled == 0
    assert [g.name for g in report.groups] == ["check"]
    assert lines[-1].startswith("warmup: every kernel was cached already (")
    assert not any("compiling" in line for line in lines)


def test_cli_prints_progress_on_stderr(monkeypatch: pytest.MonkeyPatch,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    calls: list[dict[str, object]] = []

    def fake(progress, *, workers=None, simulator=False):  # type: ignore[no-untyped-def]
        calls.append({"workers": workers, "simulator": simulator})
        progress("warmup: compiling soft fitness (4/9) ...")
        progress("warmup: done in 1.0 s (3 functions compiled)")

    monkeypatch.setattr(_warmup, "warmup", fake)
    assert main(["warmup", "--workers", "3", "--all"]) == 0
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.splitlines() == ["warmup: compiling soft fitness (4/9) ...",
                                         "warmup: done in 1.0 s (3 functions compiled)"]
    assert calls == [{"workers": 3, "simulator": True}]


def test_cli_refuses_bad_workers_and_no_cache(monkeypatch: pytest.MonkeyPatch,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["warmup", "--workers", "0"]) == 2
    assert "--workers" in capsys.readouterr().err
    import photomodel._jit as jit

    monkeypatch.setattr(jit, "CACHE", CacheChoice("none", None, (Path("/nowhere"),)))
    assert main(["warmup"]) == 2
    err = capsys.readouterr().err
    assert "no writable cache directory" in err and "/nowhere" in err


@pytest.mark.slow
def test_cold_warmup_leaves_nothing_to_compile(tmp_path: Path) -> None:
    """A full warmup from an empty NUMBA_CACHE_DIR (minutes); the second run finds it all
    cached; then a simulated scene's ``locate`` and ``identify`` compile nothing."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    cold = subprocess.run([sys.executable, "-m", "photomodel", "warmup"], env=env,
                          capture_output=True, text=True, timeout=1800, check=False)
    assert cold.returncode == 0, cold.stderr
    assert "warmup: compiling normal equations (" in cold.stderr
    assert "warmup: done in " in cold.stderr
    warm = subprocess.run([sys.executable, "-m", "photomodel", "warmup"], env=env,
                          capture_output=True, text=True, timeout=600, check=False)
    assert warm.returncode == 0, warm.stderr
    assert "every kernel was cached already" in warm.stderr
    code = textwrap.dedent(f"""
        import sys
        from photomodel._warmup import _CompileCounter
        from photomodel.camera import load_stereo
        from photomodel.identify import identify
        from photomodel.image import read_color_image
        from photomodel.locate import locate
        from photomodel.model import load_model
        from photomodel.sim import write_dataset

        out = "{tmp_path / 'data'}"
        write_dataset(out, ["No.3", "No.5"], ("paper",), scenes=1, seed=4)
        import subprocess
        for g in ("No.3", "No.5"):
            subprocess.run([sys.executable, "-m", "photomodel", "build", "--photo",
                            f"{{out}}/models/{{g}}/photo.bmp", "--background",
                            f"{{out}}/models/{{g}}/background.bmp", "--camera",
                            f"{{out}}/model_camera.yaml", "--out", f"{{out}}/lib/{{g}}.npz",
                            "--name", g], check=True, capture_output=True)
        from pathlib import Path
        rig = load_stereo(f"{{out}}/stereo.yaml")
        scene = sorted(Path(out, "scenes").iterdir())[0]
        right = read_color_image(scene / "right.png")
        left = read_color_image(scene / "left.png")
        models = [load_model(f"{{out}}/lib/{{g}}.npz") for g in ("No.3", "No.5")]
        with _CompileCounter() as counter:
            locate(models[0], rig, right, left, rng=1)
            identify(models, rig, right, left, rng=1)
        print("\\n".join(counter.functions))
    """)
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=1800, check=False)
    assert run.returncode == 0, run.stderr
    compiled = [f for f in run.stdout.split() if not f.startswith("photomodel.sim.")]
    assert compiled == []
