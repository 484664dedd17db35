"""Camera sources without the service: each kind's pairs and timestamps, the checks every pair
passes (sizes, skew), and the link that notices a stop and re-opens the source."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest

from photomodel.camera import PinholeCamera, StereoRig
from photomodel.errors import InputError
from photomodel.service._source import (
    CameraSource,
    CheckedSource,
    SourceError,
    StereoGrab,
    open_source,
    parse_source_spec,
)
from photomodel.service._source_link import SourceLink
from photomodel.sim import hand_stereo_rig

W, H = 640, 480


def _plain_rig(width: int = W, height: int = H) -> StereoRig:
    K = np.array([[800.0, 0, width / 2], [0, 800.0, height / 2], [0, 0, 1]])
    return StereoRig(PinholeCamera(K, np.zeros(5), width, height),
                     PinholeCamera(K, np.zeros(5), width, height), np.eye(3),
                     np.array([-120.0, 0, 0]))


def _image(value: int, width: int = W, height: int = H) -> np.ndarray:
    """A colour image that tells frames apart by its mean (value) and views by a bar."""
    image = np.full((height, width, 3), (value, 255 - value, 90), np.uint8)
    image[:, : width // 8] = 0
    return image


def _write_pairs(root: Path, n: int, meta: dict | None = None, size: tuple[int, int] = (W, H)
                 ) -> None:
    for k in range(n):
        folder = root / f"{k:06d}"
        folder.mkdir(parents=True)
        cv2.imwrite(str(folder / "right.png"), _image(20 * k, *size))
        cv2.imwrite(str(folder / "left.png"), _image(20 * k + 5, *size))
    if meta is not None:
        (root / "meta.json").write_text(json.dumps(meta))


def _video(path: Path, frames: int, fps: float = 30.0, size: tuple[int, int] = (W, H),
           start: int = 0) -> Path:
    """A Motion-JPEG AVI (what opencv-python-headless writes and reads back)."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, size)
    assert writer.isOpened()
    for k in range(frames):
        writer.write(_image(start + 20 * k, *size))
    writer.release()
    return path


class _Stub:
    """A source giving ``make(index)``'s pairs; ``stop`` makes its grabs fail as stopped."""

    fps = None

    def __init__(self, make: Callable[[int], StereoGrab], name: str = "stub") -> None:
        self.name = name
        self.make = make
        self.index = 0
        self.closed = False
        self.stop = False

    def grab(self, timeout_s: float, *, newest: bool = True) -> StereoGrab:
        if self.stop:
            raise SourceError(self.name, "unplugged")
        grab = self.make(self.index)
        self.index += 1
        return grab

    def close(self) -> None:
        self.closed = True

    def describe(self) -> dict:
        return {"kind": "stub"}


def _grab_at(t_right: float, t_left: float, right: np.ndarray | None = None,
             left: np.ndarray | None = None) -> Callable[[int], StereoGrab]:
    return lambda k: StereoGrab(_image(10) if right is None else right,
                                _image(20) if left is None else left, t_right, t_left, k)


# --- specs -----------------------------------------------------------------------------------


@pytest.mark.parametrize(("spec", "mention"), [
    ("", "expected a camera source"), ("usb:0", "unknown kind 'usb'"),
    ("replay:", "replay needs"), ("opencv", "opencv needs"), ("sim:", "sim:GARMENT"),
])
def test_a_bad_spec_names_the_option(spec: str, mention: str) -> None:
    with pytest.raises(InputError, match="--source") as caught:
        parse_source_spec(spec)
    assert mention in str(caught.value)


@pytest.mark.parametrize(("spec", "mention"), [
    ("opencv:0", "two cameras"), ("opencv:0,1,2", "two cameras"),
    ("sim:No.3,speed=3", "unknown option 'speed'"), ("sim:No.3,conveyor=fast", "conveyor"),
    ("sim:No.3,conveyor=5000", "0 to 1000"), ("sim:No.3,No.5", "two garments"),
])
def test_bad_arguments_name_the_option(spec: str, mention: str) -> None:
    with pytest.raises(InputError, match="--source") as caught:
        open_source(spec, hand_stereo_rig())
    assert mention in str(caught.value)


def test_a_skew_bound_out_of_range_is_refused() -> None:
    with pytest.raises(InputError, match="--max-skew-ms"):
        open_source("replay:nowhere", _plain_rig(), max_skew_ms=-1.0)


# --- the checks every pair passes ------------------------------------------------------------


def test_a_pair_further_apart_than_the_bound_is_refused_with_its_skew() -> None:
    rig = _plain_rig()
    source = CheckedSource(_Stub(_grab_at(100.0, 100.012)), rig, max_skew_ms=5.0)
    with pytest.raises(SourceError, match=r"unsynchronised cameras: the views were taken "
                                          r"12\.0 ms apart, above --max-skew-ms 5") as caught:
        source.grab(1.0)
    assert caught.value.stopped is False
    ok = CheckedSource(_Stub(_grab_at(100.0, 100.004)), rig, max_skew_ms=5.0).grab(1.0)
    assert ok.t_s == pytest.approx(100.002) and ok.skew_ms == pytest.approx(4.0)


def test_views_of_different_sizes_or_not_colour_are_refused() -> None:
    rig = _plain_rig()
    other = CheckedSource(_Stub(_grab_at(1.0, 1.0, left=_image(3, 320, 240))), rig)
    with pytest.raises(SourceError, match="views of different sizes: camera 1 .right. 640x480 "
                                          "px, camera 2 .left. 320x240 px"):
        other.grab(1.0)
    small = CheckedSource(_Stub(_grab_at(1.0, 1.0, _image(3, 320, 240), _image(3, 320, 240))),
                          rig)
    with pytest.raises(SourceError, match="calibration is for 640x480"):
        small.grab(1.0)
    grey = CheckedSource(_Stub(_grab_at(1.0, 1.0, right=np.zeros((H, W), np.uint8))), rig)
    with pytest.raises(SourceError, match=r"uint8 \(480, 640\) image; expected colour"):
        grey.grab(1.0)


# --- replay -----------------------------------------------------------------------------------


def test_replay_plays_a_sequence_at_its_rate_and_loops(tmp_path: Path) -> None:
    _write_pairs(tmp_path / "seq", 3, {"fps": 50.0})
    source = open_source(f"replay:{tmp_path / 'seq'}", _plain_rig())
    assert isinstance(source, CameraSource) and source.fps == 50.0
    t0 = time.perf_counter()
    grabs = [source.grab(1.0) for _ in range(5)]
    # consecutive frames, paced at 50 fps, the fourth the first again
    assert [g.index for g in grabs] == list(range(grabs[0].index, grabs[0].index + 5))
    assert time.perf_counter() - t0 >= 3 / 50    # the first may be due already
    assert np.diff([g.t_s for g in grabs]) == pytest.approx([0.02] * 4)
    assert all(g.t_right_s == g.t_left_s for g in grabs)
    means = [int(round(g.right_bgr[:, W // 8:, 0].mean())) for g in grabs]
    k0 = grabs[0].index
    assert means == [20 * ((k0 + i) % 3) for i in range(5)]
    assert abs(grabs[-1].t_s - time.time()) < 0.5      # the source's clock: unix seconds
    assert source.describe() == {"kind": "replay", "folder": str(tmp_path / "seq"), "pairs": 3,
                                 "fps": 50.0, "max_skew_ms": 5.0}


def test_replay_of_a_dataset_at_30_fps_by_default(tmp_path: Path) -> None:
    _write_pairs(tmp_path / "data" / "scenes", 2)
    source = open_source(f"replay:{tmp_path / 'data'}", _plain_rig())
    assert source.fps == 30.0
    a, b = source.grab(1.0), source.grab(1.0)
    assert b.t_s - a.t_s == pytest.approx((b.index - a.index) / 30.0)


def test_replay_refuses_what_it_cannot_play(tmp_path: Path) -> None:
    rig = _plain_rig()
    with pytest.raises(SourceError, match="no such folder"):
        open_source(f"replay:{tmp_path / 'nowhere'}", rig)
    (tmp_path / "empty").mkdir()
    with pytest.raises(SourceError, match="no stereo pairs"):
        open_source(f"replay:{tmp_path / 'empty'}", rig)
    _write_pairs(tmp_path / "noleft", 2)
    (tmp_path / "noleft" / "000001" / "left.png").unlink()
    with pytest.raises(SourceError, match="pair 000001 lacks left.png"):
        open_source(f"replay:{tmp_path / 'noleft'}", rig)
    _write_pairs(tmp_path / "small", 1, size=(320, 240))
    with pytest.raises(SourceError, match="calibration is for 640x480"):
        open_source(f"replay:{tmp_path / 'small'}", rig)
    _write_pairs(tmp_path / "badfps", 1, {"fps": 0})
    with pytest.raises(SourceError, match="fps 0 is not a frame rate"):
        open_source(f"replay:{tmp_path / 'badfps'}", rig)


def test_a_removed_replay_folder_stops_the_source(tmp_path: Path) -> None:
    _write_pairs(tmp_path / "seq", 2, {"fps": 100.0})
    source = open_source(f"replay:{tmp_path / 'seq'}", _plain_rig())
    source.grab(1.0)
    (tmp_path / "seq").rename(tmp_path / "away")
    with pytest.raises(SourceError, match="cannot be read") as caught:
        source.grab(1.0)
    assert caught.value.stopped


def test_a_streaming_grab_hands_over_what_a_late_reader_missed(tmp_path: Path) -> None:
    """``newest=False`` takes the oldest frame not given yet among the last BUFFERS (a driver's
    queue); the default takes the newest, as a trigger wants."""
    from photomodel.service._source_replay import BUFFERS, ReplaySource

    _write_pairs(tmp_path / "seq", 3, {"fps": 10.0})
    now = [1000.0]
    source = ReplaySource.open(str(tmp_path / "seq"), _plain_rig(), clock=lambda: now[0])
    assert source.grab(1.0).index == 0
    now[0] += 0.45                                      # frames 1 to 4 exposed meanwhile
    assert [source.grab(1.0, newest=False).index for _ in range(4)] == [1, 2, 3, 4]
    now[0] += 0.3
    assert source.grab(1.0).index == 7                  # a trigger: the newest
    now[0] += 2.0                                       # 20 frames: more than the buffers
    assert source.grab(1.0, newest=False).index == 27 - BUFFERS + 1


def test_replay_decodes_a_pair_once_and_again_when_its_file_changes(tmp_path: Path) -> None:
    _write_pairs(tmp_path / "seq", 2, {"fps": 1000.0})
    source = open_source(f"replay:{tmp_path / 'seq'}", _plain_rig())
    first = [source.grab(1.0) for _ in range(4)]
    again = {g.index % 2: g.right_bgr for g in first}
    kept = [g for g in first if g.index % 2 == first[0].index % 2]
    assert kept[0].right_bgr is kept[1].right_bgr           # decoded once, shared
    assert not kept[0].right_bgr.flags.writeable            # so nobody may draw on it
    time.sleep(0.01)
    cv2.imwrite(str(tmp_path / "seq" / "000000" / "right.png"), _image(200))
    later = [source.grab(1.0) for _ in range(2)]
    changed = next(g for g in later if g.index % 2 == 0)
    assert changed.right_bgr is not again[0]
    assert int(round(changed.right_bgr[:, W // 8:, 0].mean())) == 200


# --- opencv ----------------------------------------------------------------------------------


def test_opencv_grabs_two_video_files_in_step_until_they_end(tmp_path: Path) -> None:
    right = _video(tmp_path / "right.avi", 4)
    left = _video(tmp_path / "left.avi", 4, start=5)
    source = open_source(f"opencv:{right},{left}", _plain_rig())
    assert source.fps == pytest.approx(30.0)
    grabs = [source.grab(1.0) for _ in range(4)]
    assert [g.index for g in grabs] == [0, 1, 2, 3]
    # the files' own frame times: 30 fps, no skew between two files in step
    assert np.diff([g.t_s for g in grabs]) == pytest.approx([1 / 30] * 3, abs=1e-6)
    assert all(g.skew_ms == 0.0 for g in grabs)
    for k, g in enumerate(grabs):        # the right frames in the right order (JPEG: +-3)
        assert g.right_bgr.shape == (H, W, 3)
        assert abs(g.right_bgr[:, W // 8:, 0].mean() - 20 * k) < 3
        assert abs(g.left_bgr[:, W // 8:, 0].mean() - (20 * k + 5)) < 3
    with pytest.raises(SourceError, match=r"camera 1 \(right\) .*right.avi': end of the video"
                       ) as caught:
        source.grab(1.0)
    assert caught.value.stopped
    source.close()


def test_opencv_files_out_of_step_are_refused_as_unsynchronised(tmp_path: Path) -> None:
    right = _video(tmp_path / "right.avi", 3, fps=30.0)
    left = _video(tmp_path / "left.avi", 3, fps=20.0)
    source = open_source(f"opencv:{right},{left}", _plain_rig(), max_skew_ms=5.0)
    assert source.grab(1.0).skew_ms == 0.0                  # both at 0 ms
    with pytest.raises(SourceError, match=r"16\.7 ms apart, above --max-skew-ms 5"):
        source.grab(1.0)                                    # 33.3 ms against 50 ms
    source.close()


def test_opencv_refuses_what_it_cannot_open(tmp_path: Path) -> None:
    rig = _plain_rig()
    with pytest.raises(InputError, match=r"--source: opencv: camera 1 \(right\) '97': cannot "
                                         "open this device"):
        open_source("opencv:97,98", rig)
    right = _video(tmp_path / "right.avi", 2)
    with pytest.raises(InputError, match=r"camera 2 \(left\) '.*missing.avi': cannot open"):
        open_source(f"opencv:{right},{tmp_path / 'missing.avi'}", rig)
    small = _video(tmp_path / "small.avi", 2, size=(320, 240))
    with pytest.raises(SourceError, match="views of different sizes: camera 1 .right. 640x480 "
                                          "px, camera 2 .left. 320x240 px"):
        open_source(f"opencv:{right},{small}", rig)
    with pytest.raises(SourceError, match="gives 320x240 px but the calibration is for "
                                          "640x480 px"):
        open_source(f"opencv:{small},{small}", rig)


# --- sim ---------------------------------------------------------------------------------------


def test_sim_renders_the_hand_cameras_at_the_clock_and_refuses_another_rig() -> None:
    now = [1000.0]
    source = open_source("sim:No.3,conveyor=200", hand_stereo_rig(), clock=lambda: now[0])
    assert source.name == "sim:No.3,conveyor=200" and source.fps is None
    first = source.grab(5.0)
    T0 = source.source.last_T_cam1_model
    now[0] += 0.1
    second = source.grab(5.0)
    T1 = source.source.last_T_cam1_model
    assert (first.t_s, second.t_s) == (1000.0, 1000.1) and second.skew_ms == 0.0
    assert first.right_bgr.shape == (H, W, 3) and second.index == first.index + 1
    assert T0 is not None and T1 is not None
    # 0.1 s of a 200 mm/s belt: 20 mm, the same way in camera 1's frame as in the table's
    assert np.linalg.norm(T1[:3, 3] - T0[:3, 3]) == pytest.approx(20.0, abs=0.01)
    with pytest.raises(InputError, match="--source: sim renders the simulated hand rig"):
        open_source("sim", _plain_rig())
    with pytest.raises(InputError, match="no catalogue garment 'No.99'"):
        open_source("sim:No.99", hand_stereo_rig())


# --- the service's link: stop, retry, recover --------------------------------------------------


def test_the_link_reopens_a_stopped_source_in_the_background() -> None:
    opened: list[_Stub] = []
    gone = threading.Event()

    def opener() -> CameraSource:
        if gone.is_set():
            raise SourceError("stub", "still unplugged")
        stub = _Stub(_grab_at(5.0, 5.0))
        opened.append(stub)
        return stub

    link = SourceLink(opener)
    try:
        assert link.grab().index == 0 and link.health()["state"] == "ok"
        opened[0].stop = True
        gone.set()
        with pytest.raises(SourceError, match="stopped: unplugged; re-opening it every 1-5 s"):
            link.grab()
        assert opened[0].closed and not link.up
        health = link.health()
        assert health["state"] == "down" and health["stops"] == 1
        with pytest.raises(SourceError, match="stopped"):       # at once while down
            link.grab()
        time.sleep(1.3)                                         # one failed re-open
        assert "re-opening failed (stub: still unplugged)" in link.health()["detail"]
        gone.clear()
        deadline = time.monotonic() + 6.0
        while not link.up and time.monotonic() < deadline:
            time.sleep(0.05)
        assert link.up and link.health()["reopened"] == 1 and len(opened) == 2
        assert link.grab().index == 0                          # the new source's first pair
    finally:
        link.close()


def test_a_refused_pair_leaves_the_source_open() -> None:
    link = SourceLink(lambda: CheckedSource(_Stub(_grab_at(1.0, 1.5)), _plain_rig()))
    with pytest.raises(SourceError, match="500.0 ms apart"):
        link.grab()
    health = link.health()
    assert link.up and health["state"] == "ok" and health["refused"] == 1
    assert "500.0 ms apart" in health["last_error"]
    link.close()


# --- genicam (harvesters, with the simulated GenTL producer the genicam package ships) -------


@pytest.mark.parametrize(("fmt", "pixel", "bgr"), [
    ("BGR8", [1, 2, 3], [1, 2, 3]), ("RGB8", [1, 2, 3], [3, 2, 1]),
    ("BGRa8", [1, 2, 3, 9], [1, 2, 3]), ("RGBa8", [1, 2, 3, 9], [3, 2, 1]),
])
def test_genicam_pixels_become_bgr(fmt: str, pixel: list[int], bgr: list[int]) -> None:
    from photomodel.service._source_genicam import to_bgr

    data = np.tile(np.array(pixel, np.uint8), 6)            # 3 x 2 pixels, row after row
    image = to_bgr(data, 3, 2, fmt)
    assert image.shape == (2, 3, 3) and image.dtype == np.uint8
    assert (image == np.array(bgr, np.uint8)).all()
    with pytest.raises(ValueError, match="expected"):
        to_bgr(data[:-1], 3, 2, fmt)
    with pytest.raises(ValueError, match="pixel format Mono8 is not read"):
        to_bgr(data, 3, 2, "Mono8")


@pytest.fixture(scope="module")
def viky() -> Path:
    """The genicam package's simulated GenTL producer: three 400 x 400 RGBa8 cameras at 20
    fps ('red', 'green', 'blue': a ball of that colour bouncing on white)."""
    pytest.importorskip("harvesters")
    genicam = pytest.importorskip("genicam")
    path = Path(genicam.__file__).with_name("viky.cti")
    if not path.is_file():
        pytest.skip("this genicam package ships no viky.cti")
    return path


def test_genicam_grabs_two_cameras_at_the_calibrations_size(viky: Path) -> None:
    source = open_source(f"genicam:0,1,cti={viky}", _plain_rig(), max_skew_ms=60.0)
    try:
        assert source.fps == 20.0
        assert source.describe()["kind"] == "genicam"
        grabs = [source.grab(5.0) for _ in range(3)]
    finally:
        source.close()
    for g in grabs:
        assert g.right_bgr.shape == g.left_bgr.shape == (H, W, 3)    # set from 400 x 400
        assert abs(g.t_s - time.time()) < 5.0 and g.skew_ms <= 60.0
        # BGR from RGBa: camera 1 is the red camera, camera 2 the green one
        assert g.right_bgr.reshape(-1, 3).min(0).tolist() == [0, 0, 255]
        assert g.left_bgr.reshape(-1, 3).min(0).tolist() == [0, 255, 0]
    assert [g.index for g in grabs] == [0, 1, 2]
    # each grab waits for new frames (20 fps: 50 ms apart)
    assert np.diff([g.t_right_s for g in grabs]).min() > 0.03


def test_genicam_selects_cameras_by_id_and_refuses_what_it_cannot_open(
        viky: Path, monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    rig = _plain_rig()
    source = open_source(f"genicam:VikyTL_DEV_blue,VikyTL_DEV_red,cti={viky}", rig,
                         max_skew_ms=60.0)
    try:
        assert source.grab(5.0).right_bgr.reshape(-1, 3).min(0).tolist() == [255, 0, 0]
    finally:
        source.close()
    with pytest.raises(InputError, match=r"--source: genicam: camera 2 \(left\) 'nope': no such "
                                         r"device \(found: 0 \(VikyTL_DEV_red\)"):
        open_source(f"genicam:0,nope,cti={viky}", rig)
    with pytest.raises(InputError, match="the same camera"):
        open_source(f"genicam:0,VikyTL_DEV_red,cti={viky}", rig)
    with pytest.raises(InputError, match="expected two cameras"):
        open_source(f"genicam:0,cti={viky}", rig)
    with pytest.raises(InputError, match="no such file"):
        open_source(f"genicam:0,1,cti={tmp_path / 'none.cti'}", rig)
    monkeypatch.setenv("GENICAM_GENTL64_PATH", str(tmp_path))
    with pytest.raises(InputError, match="no GenTL producer: give cti=PATH or set "
                                         "GENICAM_GENTL64_PATH"):
        open_source("genicam:0,1", rig)
    monkeypatch.setenv("GENICAM_GENTL64_PATH", str(viky.parent))    # the standard's way
    source = open_source("genicam:1,2", rig, max_skew_ms=60.0)
    source.close()
