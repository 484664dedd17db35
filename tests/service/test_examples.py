"""The examples in ``examples/``: the standard-library client run as a user runs it (a
subprocess against a running service), and the ROS 2 node's conversion of an answer's
``pose_stamped`` into ``geometry_msgs/PoseStamped`` fields (without ROS)."""

from __future__ import annotations

import importlib.util
import math
import os
import re
import subprocess
import sys
import time
from pathlib import Path
from types import ModuleType

import httpx
import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
CLIENT = EXAMPLES / "locate_client.py"
TIMEOUT_S = 300.0
LINE = re.compile(r"found=(True|False) position_mm=\[(\S+), (\S+), (\S+)\] theta_deg=(\S+) "
                  r"score=(\S+) id=(\w+)")


def _example(name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"examples_{name}", EXAMPLES / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _client(url: str, model: str, scene: Path, *extra: str, token: str | None = None
            ) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "PHOTOMODEL_TOKEN"}
    if token is not None:
        env["PHOTOMODEL_TOKEN"] = token
    return subprocess.run([sys.executable, str(CLIENT), url, model, str(scene / "right.png"),
                           str(scene / "left.png"), *extra], capture_output=True, text=True,
                          env=env, timeout=TIMEOUT_S, check=False)


def test_client_prints_the_pose(service, cell_data) -> None:
    scene = cell_data.scene_of("No.3")
    run = _client(service.url, "No.3", scene, "7")
    assert run.returncode == 0 and run.stderr == "", run
    match = LINE.fullmatch(run.stdout.strip())
    assert match, run.stdout
    found, x, y, z, theta, score, rid = match.groups()
    assert found == "True"
    truth = cell_data.truth[scene.name]
    position = np.array([float(x), float(y), float(z)])
    assert np.linalg.norm(position - np.array(truth["T_cam1_model"])[:3, 3]) < 5.0
    # the printed numbers are the service's own, rounded (the id names the stored answer)
    answer = httpx.get(f"{service.url}/results/{rid}").json()
    np.testing.assert_allclose(position, answer["position_mm"], atol=0.05 + 1e-9)
    assert float(theta) == pytest.approx(answer["theta_deg"], abs=0.005 + 1e-9)
    assert float(score) == pytest.approx(answer["score"], abs=0.0005 + 1e-9)


def test_client_raw_prints_the_same_pose(service, cell_data) -> None:
    """--raw sends the same pixels as raw BGR: the same pose as the PNG upload."""
    scene = cell_data.scene_of("No.3")
    png, raw = (_client(service.url, "No.3", scene, "7", *extra) for extra in ((), ("--raw",)))
    assert png.returncode == 0 and raw.returncode == 0 and raw.stderr == "", raw
    match_png, match_raw = (LINE.fullmatch(run.stdout.strip()) for run in (png, raw))
    assert match_png and match_raw, raw.stdout
    assert match_png.groups()[:6] == match_raw.groups()[:6]
    assert match_png.group(7) != match_raw.group(7)        # two results


@pytest.mark.parametrize(("model", "extra", "status", "mention"), [
    ("No.9", (), 404, "'No.9'"),            # not in the library
    ("No.3", ("x",), 400, "seed"),          # not a seed
])
def test_client_4xx_is_one_line(service, cell_data, model: str, extra: tuple[str, ...],
                                status: int, mention: str) -> None:
    run = _client(service.url, model, cell_data.scene_of("No.3"), *extra)
    assert run.returncode != 0 and run.stdout == "", run
    lines = run.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error {status}: "), run.stderr
    assert mention in lines[0]
    assert httpx.get(f"{service.url}/health").json()["status"] == "ok"


def test_client_usage_and_no_service(cell_data) -> None:
    run = subprocess.run([sys.executable, str(CLIENT)], capture_output=True, text=True,
                         timeout=TIMEOUT_S, check=False)
    assert run.returncode != 0 and "usage: python locate_client.py URL MODEL" in run.stderr
    # a port nothing listens on (bound, never listened to)
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        run = _client(f"http://127.0.0.1:{s.getsockname()[1]}", "No.3",
                      cell_data.scene_of("No.3"))
    assert run.returncode != 0 and run.stdout == ""
    assert run.stderr.startswith("error: ") and len(run.stderr.splitlines()) == 1, run.stderr


def test_client_sends_the_token(cell_data, tmp_path) -> None:
    """The token of PHOTOMODEL_TOKEN passes the guard: a cold service (no warm-up, so
    quick) answers 503 'warming' to it and 401 to no token or a wrong one."""
    from photomodel.service import CellService, ServiceConfig, ServiceThread

    token = "example-token-0123456789"
    cell = CellService(ServiceConfig(stereo=cell_data.stereo, models=tmp_path / "library",
                                     token=token))
    scene = cell_data.scene_of("No.3")
    with ServiceThread(cell, warm=False) as running:
        refused = _client(running.url, "No.3", scene)
        wrong = _client(running.url, "No.3", scene, token=token + "x")
        passed = _client(running.url, "No.3", scene, token=token)
    for run in (refused, wrong):
        assert run.returncode != 0 and run.stderr.startswith("error 401: "), run.stderr
        assert "bearer token" in run.stderr
    assert passed.returncode != 0 and passed.stderr.startswith("error 503: "), passed.stderr
    assert "warming" in passed.stderr


# --- the ROS 2 node's conversion --------------------------------------------------------------

@pytest.fixture(scope="module")
def ros2_forward() -> ModuleType:
    module = _example("ros2_forward")
    assert "rclpy" not in sys.modules     # nothing of ROS at import: main() imports it
    return module


@pytest.fixture(scope="module")
def answer(service, cell_data) -> dict:
    """A real /locate answer, through the client's own ``locate`` function."""
    scene = cell_data.scene_of("No.3")
    locate = _example("locate_client").locate
    return locate(service.url, "No.3", (scene / "right.png").read_bytes(),
                  (scene / "left.png").read_bytes(), "5")


def test_pose_fields_of_a_real_answer(ros2_forward, answer) -> None:
    before = time.time()
    assert answer["found"]
    fields = ros2_forward.pose_fields(answer["pose_stamped"])
    # exactly geometry_msgs/PoseStamped's fields, with the types its setters accept
    assert fields.keys() == {"header", "pose"}
    assert fields["header"].keys() == {"frame_id", "stamp"}
    assert fields["header"]["stamp"].keys() == {"sec", "nanosec"}
    assert fields["pose"].keys() == {"position", "orientation"}
    assert list(fields["pose"]["position"]) == ["x", "y", "z"]
    assert list(fields["pose"]["orientation"]) == ["x", "y", "z", "w"]
    assert fields["header"]["frame_id"] == "cam1"
    sec, nanosec = fields["header"]["stamp"]["sec"], fields["header"]["stamp"]["nanosec"]
    assert type(sec) is int and type(nanosec) is int and 0 <= nanosec < 1_000_000_000
    stamp = answer["pose_stamped"]["header"]["stamp"]
    assert sec + nanosec * 1e-9 == pytest.approx(stamp, abs=1e-6)
    assert before - 600 < stamp <= before
    # metres = mm / 1000; the quaternion is unit and the answer's quat_wxyz in xyzw order
    position = [fields["pose"]["position"][k] for k in "xyz"]
    np.testing.assert_allclose(position, np.array(answer["position_mm"]) / 1000, atol=1e-12)
    q = fields["pose"]["orientation"]
    assert all(type(q[k]) is float for k in "xyzw")
    assert math.fsum(q[k] ** 2 for k in "xyzw") == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose([q["w"], q["x"], q["y"], q["z"]], answer["quat_wxyz"],
                               atol=1e-9)
    # the same rotation as the answer's T_cam1_model
    w, x, y, z = q["w"], q["x"], q["y"], q["z"]
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                  [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                  [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    np.testing.assert_allclose(R, np.array(answer["T_cam1_model"])[:3, :3], atol=1e-9)
    # a frame of the robot's tree instead of the service's cam1
    renamed = ros2_forward.pose_fields(answer["pose_stamped"], "right_camera_optical_frame")
    assert renamed["header"]["frame_id"] == "right_camera_optical_frame"
    assert renamed["pose"] == fields["pose"]


@pytest.mark.parametrize(("stamp", "expected"), [
    (0.0, (0, 0)),
    (1.5, (1, 500_000_000)),
    (1.9999999999, (2, 0)),                 # rounds up into the next second, never 1e9 ns
    (1_700_000_000.25, (1_700_000_000, 250_000_000)),
])
def test_stamp_time(ros2_forward, stamp: float, expected: tuple[int, int]) -> None:
    assert ros2_forward.stamp_time(stamp) == expected


def test_pose_fields_normalises_and_refuses_no_rotation(ros2_forward) -> None:
    ps = {"header": {"frame_id": "cam1", "stamp": 12.0},
          "pose": {"position": {"x": 0.1, "y": -0.2, "z": 0.7},
                   "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 2.0}}}
    fields = ros2_forward.pose_fields(ps)
    assert fields["pose"]["orientation"] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
    assert fields["header"]["stamp"] == {"sec": 12, "nanosec": 0}
    ps["pose"]["orientation"]["w"] = 0.0
    with pytest.raises(ValueError, match="not a rotation"):
        ros2_forward.pose_fields(ps)


def test_track_client_streams_a_sequence(service, cell_data, tmp_path) -> None:
    """The /track example run as a user runs it: a folder of frames sent at 30 fps, one line
    per tracked frame."""
    import shutil

    scene = cell_data.scene_of("No.3")
    for k in range(5):
        shutil.copytree(scene, tmp_path / "seq" / f"{k:06d}")
    run = subprocess.run([sys.executable, str(EXAMPLES / "track_client.py"), service.url,
                          "No.3", str(tmp_path / "seq"), "30"], capture_output=True, text=True,
                         timeout=TIMEOUT_S, check=False)
    assert run.returncode == 0 and run.stderr == "", run
    lines = run.stdout.splitlines()
    assert lines and lines[0].startswith("frame 0: detect x=")
    assert all(re.match(r"frame \d+: (detect|track) x=", line) for line in lines)
    # answers on demand: the same lines, one per answer asked for
    asked = subprocess.run([sys.executable, str(EXAMPLES / "track_client.py"), "--credit",
                            service.url, "No.3", str(tmp_path / "seq"), "30"],
                           capture_output=True, text=True, timeout=TIMEOUT_S, check=False)
    assert asked.returncode == 0 and asked.stderr == "", asked
    lines = asked.stdout.splitlines()
    assert lines and lines[0].startswith("frame 0: detect x=")
    assert all(re.match(r"frame \d+: (detect|track) x=.*\((\d+) dropped\)$", line)
               for line in lines)
    bad = subprocess.run([sys.executable, str(EXAMPLES / "track_client.py"), service.url,
                          "nope", str(tmp_path / "seq")], capture_output=True, text=True,
                         timeout=TIMEOUT_S, check=False)
    assert bad.returncode == 1 and "no model named 'nope'" in bad.stderr
