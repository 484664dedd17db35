"""Nothing a user sends crashes a command, hangs it or loses their data (issue 40).

- A library with a damaged or foreign model file still lists, shows, adds, removes and
  identifies: one warning line per bad file.
- Model names that would garble a listing are refused with one line.
- Two experiments into one run directory: the second is refused, naming the first's pid.
- A run killed with SIGKILL leaves no worker process behind and no duplicated record; the
  rerun resumes.
- ``simulate --force`` replaces only a dataset, never a file or another directory.
- Every option error: one line naming the option and the allowed range, exit 2, no traceback,
  nothing written.
"""

from __future__ import annotations

import csv
import json
import os
import random
import signal
import subprocess
import sys
import textwrap
import time
from collections import Counter
from pathlib import Path

import cv2
import numpy as np
import pytest

from photomodel.camera import save_camera, save_stereo
from photomodel.cli import main
from photomodel.cli._main import build_parser
from photomodel.model import save_model
from photomodel.sim import random_stereo_scene


def _run(capsys: pytest.CaptureFixture[str], argv: list[object]) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _one_error_line(code: int, out: str, err: str, *mentions: str) -> str:
    assert code == 2, (out, err)
    assert "Traceback" not in err and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("photomodel: error: "), lines[0]
    for text in mentions:
        assert text in lines[0], (text, lines[0])
    return lines[0]


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory, plain_case) -> dict[str, Path]:  # type: ignore[no-untyped-def]
    """A model file, its model photos and camera, a stereo file and a stereo pair of it."""
    root = tmp_path_factory.mktemp("reliability")
    paths = {k: root / v for k, v in (("model", "shirt.npz"), ("photo", "photo.bmp"),
                                      ("background", "background.bmp"),
                                      ("camera", "model_camera.yaml"),
                                      ("stereo", "stereo.yaml"), ("right", "right.png"),
                                      ("left", "left.png"))}
    save_model(plain_case.built.model, paths["model"])
    save_camera(paths["camera"], plain_case.camera, distance_mm=400)
    save_stereo(paths["stereo"], plain_case.rig)
    scene = random_stereo_scene(plain_case.garment, plain_case.rig, rng=3)
    for key, image in (("photo", plain_case.photo), ("background", plain_case.background),
                       ("right", scene.right_bgr), ("left", scene.left_bgr)):
        assert cv2.imwrite(str(paths[key]), image)
    return paths


# --- a library that survives its worst file ----------------------------------------------------


def _damaged_library(root: Path, model: Path) -> Path:
    lib = root / "lib"
    assert main(["models", "add", "--models", str(lib), str(model), "--name", "shirt"]) == 0
    raw = bytearray(model.read_bytes())
    raw[len(raw) // 2] ^= 0xFF                       # a flipped byte
    (lib / "flipped.npz").write_bytes(bytes(raw))
    with np.load(model) as data:                      # a newer format version
        arrays = {k: data[k] for k in data.files}
    meta = json.loads(str(arrays["meta"]))
    arrays["meta"] = np.array(json.dumps({**meta, "version": "two"}))
    np.savez(lib / "version.npz", **arrays)
    return lib


def test_models_commands_and_identify_survive_bad_files(capsys, tmp_path: Path,
                                                        files: dict[str, Path]) -> None:
    lib = _damaged_library(tmp_path, files["model"])
    capsys.readouterr()

    def warnings(err: str) -> list[str]:
        lines = err.strip().splitlines()
        assert all(line.startswith("photomodel: warning: ") for line in lines), err
        return sorted(Path(line.split(": ")[2]).name for line in lines)

    code, out, err = _run(capsys, ["models", "list", "--models", lib])
    assert code == 0 and "shirt" in out and "1 model(s)" in out
    assert warnings(err) == ["flipped.npz", "version.npz"]
    code, out, err = _run(capsys, ["models", "show", "--models", lib, "shirt"])
    assert code == 0 and "name        shirt" in out
    code, out, err = _run(capsys, ["models", "add", "--models", lib, files["model"],
                                   "--name", "second"])
    assert code == 0 and "added second" in out
    code, out, err = _run(capsys, ["identify", "--models", lib, "--stereo", files["stereo"],
                                   "--right", files["right"], "--left", files["left"],
                                   "--json"])
    assert code == 0, err
    assert json.loads(out)["model"] in ("shirt", "second", None)
    assert warnings(err) == ["flipped.npz", "version.npz"]
    code, out, err = _run(capsys, ["models", "remove", "--models", lib, "second"])
    assert code == 0 and "removed second" in out


@pytest.mark.parametrize("name", ["two\nlines", "evil\u202eman", "a/b", "x" * 101])
def test_models_add_refuses_names_that_garble_a_listing(capsys, tmp_path: Path,
                                                        files: dict[str, Path],
                                                        name: str) -> None:
    lib = tmp_path / "lib"
    line = _one_error_line(*_run(capsys, ["models", "add", "--models", lib, files["model"],
                                          "--name", name]), "--name", "cannot be a model name")
    assert line.isprintable()
    assert not lib.exists() or not list(lib.glob("*.npz"))


# --- runs that protect their results -----------------------------------------------------------


def _hold_lock(directory: Path) -> subprocess.Popen[str]:
    """Another process holding the run directory's lock, as a running experiment does."""
    code = textwrap.dedent(f"""
        import fcntl, os, sys, time
        fd = os.open({str(directory / '.lock')!r}, os.O_RDWR | os.O_CREAT)
        fcntl.flock(fd, fcntl.LOCK_EX)
        os.write(fd, b"%d\\n" % os.getpid())
        print("held", flush=True)
        time.sleep(120)
    """)
    holder = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
    return holder


@pytest.mark.parametrize("identify", [False, True])
def test_a_second_run_into_the_same_directory_is_refused(capsys, tmp_path: Path,
                                                         identify: bool) -> None:
    out = tmp_path / "run"
    out.mkdir()
    (out / "records.csv").write_text("kept\n")
    holder = _hold_lock(out)
    try:
        argv = ["experiment", "--out", out, "--garments", "No.3", "--trials", "1",
                "--workers", "1", "--no-report", *(["--identify"] if identify else [])]
        line = _one_error_line(*_run(capsys, argv), str(out), f"process {holder.pid}",
                               "another run")
    finally:
        holder.kill()
        holder.wait()
    assert line.count(str(out)) == 1                      # no doubled prefix
    assert (out / "records.csv").read_text() == "kept\n"
    from photomodel.experiments._lock import run_lock

    with run_lock(out), run_lock(out):                    # the dead holder's lock is free,
        pass                                              # and this process may re-enter


def _children(pid: int) -> set[int]:
    """Descendants of ``pid`` (Linux /proc)."""
    parents: dict[int, int] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            parents[int(entry)] = int(stat.rsplit(")", 1)[1].split()[1])
    found, frontier = set(), {pid}
    while frontier:
        frontier = {c for c, p in parents.items() if p in frontier} - found
        found |= frontier
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")


def _wait_gone(pids: set[int], seconds: float) -> set[int]:
    deadline = time.monotonic() + seconds
    alive = {p for p in pids if _alive(p)}
    while alive and time.monotonic() < deadline:
        time.sleep(0.1)
        alive = {p for p in alive if _alive(p)}
    return alive


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_workers_end_when_their_run_is_killed(tmp_path: Path) -> None:
    """A pool's workers (and so the resource tracker) exit within seconds of a SIGKILL of the
    process that started them."""
    script = tmp_path / "parent.py"
    script.write_text(textwrap.dedent("""
        import time
        from photomodel.experiments._run import pool_stream

        def slow(config, trial):
            time.sleep(300)
            return {}

        if __name__ == "__main__":
            for _ in pool_stream(slow, None, [1, 2, 3], 2):
                pass
    """))
    parent = subprocess.Popen([sys.executable, str(script)])
    try:
        deadline = time.monotonic() + 120
        workers: set[int] = set()
        while time.monotonic() < deadline and len(workers) < 3:   # 2 workers + tracker
            time.sleep(0.2)
            workers = _children(parent.pid)
        assert len(workers) >= 3, workers
        time.sleep(3.0)          # the workers are past their start-up, running a task
    finally:
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait()
    left = _wait_gone(workers, 10.0)
    for pid in left:             # do not leave them behind even when the test fails
        os.kill(pid, signal.SIGKILL)
    assert left == set()


def _record_ids(path: Path) -> list[str]:
    if not path.exists():
        return []
    with path.open(newline="") as f:
        return [r["trial_id"] for r in csv.DictReader(f) if r.get("stop_reason")]


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_experiment_killed_at_random_moments_resumes_without_orphans(tmp_path: Path) -> None:
    """SIGKILL ``photomodel experiment`` 3 times at random moments: no process left, no
    record lost or duplicated, the rerun completes the study."""
    out = tmp_path / "run"
    argv = [sys.executable, "-m", "photomodel", "experiment", "--out", str(out), "--garments",
            "No.3", "--trials", "40", "--workers", "2", "--generations", "3", "--no-report"]
    rng = random.Random(3)
    before: set[str] = set()
    for _ in range(3):
        proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        deadline = time.monotonic() + rng.uniform(4.0, 20.0)
        seen: set[int] = set()
        while time.monotonic() < deadline and proc.poll() is None:
            seen |= _children(proc.pid)
            time.sleep(0.1)
        if proc.poll() is None:
            proc.kill()
        _, err = proc.communicate()
        assert proc.returncode in (0, -signal.SIGKILL), err
        left = _wait_gone(seen, 10.0)
        for pid in left:
            os.kill(pid, signal.SIGKILL)
        assert left == set()
        ids = _record_ids(out / "records.csv")
        assert max(Counter(ids).values(), default=1) == 1
        assert before <= set(ids)
        before = set(ids)
    done = subprocess.run(argv, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    ids = _record_ids(out / "records.csv")
    assert len(ids) == len(set(ids)) == 40


# --- simulate --force replaces only a dataset --------------------------------------------------


def test_simulate_force_never_replaces_a_file_or_a_foreign_directory(capsys,
                                                                     tmp_path: Path) -> None:
    folder = tmp_path / "photos"
    folder.mkdir()
    (folder / "holiday.jpg").write_bytes(b"precious")
    a_file = tmp_path / "notes.txt"
    a_file.write_text("precious")
    for out, mention in ((folder, "not a dataset"), (a_file, "not a directory")):
        argv = ["simulate", "--out", out, "--garments", "No.3", "--conditions", "no-target",
                "--force"]
        _one_error_line(*_run(capsys, argv), str(out), mention)
    assert (folder / "holiday.jpg").read_bytes() == b"precious"
    assert a_file.read_text() == "precious"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt", "photos"]


def test_simulate_clears_what_a_killed_simulate_left(capsys, tmp_path: Path) -> None:
    """A ``kill -9`` leaves the half-built ``.DIR.partial-PID``; the next run removes it (its
    process is gone) and ``--force`` then replaces the dataset it wrote."""
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()
    partial = tmp_path / f".ds.partial-{dead}"
    (partial / "scenes").mkdir(parents=True)
    argv = ["simulate", "--out", tmp_path / "ds", "--garments", "No.3", "--conditions",
            "no-target"]
    code, out, err = _run(capsys, argv)
    assert code == 0, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]
    code, out, err = _run(capsys, [*argv, "--force", "--seed", "1"])
    assert code == 0, err
    assert json.loads((tmp_path / "ds" / "dataset.json").read_text())["seed"] == 1


# --- quiet, exact option errors ----------------------------------------------------------------


@pytest.mark.parametrize(("argv", "line"), [
    (["simulate", "--seed", "-1"], "--seed: expected an integer from 0 to 4294967295, got -1"),
    (["simulate", "--scenes", "1000000000"],
     "--scenes: expected an integer from 1 to 10000, got 1000000000"),
    (["simulate", "--scenes", "0"], "--scenes: expected an integer from 1 to 10000, got 0"),
    (["simulate", "--add-garment", "a\nb", "x.png", "m.png", "200"], "--add-garment: "),
    (["experiment", "--generations", "0"],
     "--generations: expected an integer from 1 to 100000, got 0"),
    (["experiment", "--seed", "-1"], "--seed: expected an integer from 0 to 4294967295"),
    (["experiment", "--trials", "1000000000"], "--trials: expected an integer from 1 to"),
    (["experiment", "--scheduler", "not an address"],
     "--scheduler: expected a Dask scheduler address such as tcp://host:8786"),
    (["experiment", "--scheduler", "tcp://localhost:99999"], "--scheduler: expected"),
    (["experiment", "--identify", "--max-candidates", "0"],
     "--max-candidates: expected an integer from 1 to 1000, got 0"),
    (["experiment", "--identify", "--negative-trials", "-1"], "--negative-trials: expected"),
    (["experiment", "--identify", "--min-score", "3"],
     "--min-score: expected a number from 0 to 1, got 3"),
    (["cell", "--orders", "0"], "--orders: expected an integer from 1 to 100000, got 0"),
    (["cell", "--tolerance-mm", "-3"], "--tolerance-mm: expected a number greater than 0"),
    (["cell", "--conditions", "sunny"], "--conditions: "),
    (["cell", "--seed", "-2"], "--seed: expected an integer from 0 to"),
    (["cell", "--box-size-mm", "0"],
     "--box-size-mm: expected a number greater than 0 and at most 5000 mm, got 0"),
    (["cell", "--box-mm", "300", "nan", "0"], "--box-mm (y): expected a number from -5000"),
    (["cell", "--approach-mm", "-1"], "--approach-mm: expected a number from 0 to 5000 mm"),
    (["cell", "--box-yaw-deg", "inf"], "--box-yaw-deg: expected a number from -360 to 360"),
    (["demo", "--seed", "-1"], "--seed: expected an integer from 0 to 4294967295, got -1"),
])
def test_option_errors_name_the_option_and_the_range(capsys, tmp_path: Path, argv: list[str],
                                                     line: str) -> None:
    out = tmp_path / "out"
    full = [argv[0], "--out", out, *argv[1:]]
    got = _one_error_line(*_run(capsys, full))
    assert got.startswith(f"photomodel: error: {line}"), got
    assert not out.exists()


def test_an_unreachable_scheduler_fails_fast_naming_the_option(capsys, tmp_path: Path) -> None:
    import socket

    with socket.socket() as s:                  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    out = tmp_path / "run"
    t0 = time.monotonic()
    line = _one_error_line(*_run(capsys, ["experiment", "--out", out, "--garments", "No.3",
                                          "--trials", "1", "--scheduler",
                                          f"tcp://127.0.0.1:{port}", "--no-report"]),
                           "--scheduler", "cannot reach")
    assert time.monotonic() - t0 < 20, line
    assert not out.exists()


def test_other_settings_are_named_once(capsys, tmp_path: Path) -> None:
    out = tmp_path / "run"
    out.mkdir()
    (out / "config.json").write_text(json.dumps({"garments": ["No.5"]}))
    line = _one_error_line(*_run(capsys, ["experiment", "--out", out, "--garments", "No.3",
                                          "--trials", "1", "--workers", "1", "--no-report"]),
                           "other settings")
    assert line.count(str(out)) == 1, line


@pytest.mark.parametrize(("extra", "line"), [
    (["--step-mm", "1000"], "--step-mm: expected a number from 0.5 to 20 mm, got 1000"),
    (["--step-mm", "nan"], "--step-mm: expected a number from 0.5 to 20 mm"),
    (["--band-width-mm", "-1"], "--band-width-mm: expected a number from 0 to 100 mm"),
    (["--hue-threshold-deg", "0"], "--hue-threshold-deg: expected a number greater than 0"),
    (["--distance-mm", "inf"], "--distance-mm: expected a number greater than 0 and at most"),
    (["--name", "two\nlines"], "--name: "),
])
def test_build_option_errors(capsys, tmp_path: Path, files: dict[str, Path], extra: list[str],
                             line: str) -> None:
    out = tmp_path / "m.npz"
    argv = ["build", "--photo", files["photo"], "--background", files["background"],
            "--camera", files["camera"], "--out", out, *extra]
    got = _one_error_line(*_run(capsys, argv))
    assert got.startswith(f"photomodel: error: {line}"), got
    assert not out.exists()


def test_build_with_an_infinite_distance_in_the_camera_file(capsys, tmp_path: Path,
                                                            files: dict[str, Path]) -> None:
    camera = tmp_path / "cam.yaml"
    text = files["camera"].read_text()
    camera.write_text("\n".join("distance_mm: .inf" if line.startswith("distance_mm")
                                else line for line in text.splitlines()) + "\n")
    out = tmp_path / "m.npz"
    _one_error_line(*_run(capsys, ["build", "--photo", files["photo"], "--background",
                                   files["background"], "--camera", camera, "--out", out]),
                    "cam.yaml", "distance_mm")
    assert not out.exists()


@pytest.mark.parametrize(("extra", "option", "unit"), [
    (["--x-mm", "100", "-100"], "--x-mm", "mm"), (["--z-mm", "-5", "900"], "--z-mm", "mm"),
    (["--theta-deg", "200"], "--theta-deg", "deg"),
    (["--theta-deg", "180", "--tilt-deg", "10"], "--tilt-deg", "deg"),
])
def test_search_space_errors_speak_in_the_users_units(capsys, files: dict[str, Path],
                                                      extra: list[str], option: str,
                                                      unit: str) -> None:
    argv = ["locate", "--model", files["model"], "--stereo", files["stereo"], "--right",
            files["right"], "--left", files["left"], *extra]
    line = _one_error_line(*_run(capsys, argv), f"error: {option}: ", unit)
    assert "[" not in line and "e-0" not in line      # no numpy arrays, no radians


def test_the_same_thing_has_the_same_flag_in_every_command() -> None:
    parser = build_parser()
    for flag in ("--condition", "--conditions"):
        assert parser.parse_args(["cell", flag, "wood"]).condition == "wood"
        assert parser.parse_args(["demo", flag, "wood"]).conditions == "wood"
    for flag in ("--garment", "--garments"):
        assert parser.parse_args(["demo", flag, "No.1"]).garments == "No.1"
