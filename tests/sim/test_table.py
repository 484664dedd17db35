"""Simulated tables: piles of garments, their render and truth, and ``simulate --table``.

The visible fractions come from the render (one pass per camera tracks every garment); they
are checked against an independent computation in the table plane (the share of a garment's
footprint that no footprint above it covers), and ``covered_by`` against the layers.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from photomodel.camera import StereoRig
from photomodel.cli import main
from photomodel.sim import (
    CLOTH_THICKNESS_MM,
    GarmentTruth,
    TableLayout,
    TableShot,
    catalogue_garment,
    garment_names,
    garment_placement,
    hand_table_pose,
    parse_conditions,
    random_table,
    render_view_linear,
    simulate_table,
    write_dataset,
)
from photomodel.sim._footprint import footprint, union
from photomodel.sim._table import _in_image_fraction

POOL = tuple(catalogue_garment(name) for name in garment_names())


@pytest.fixture(scope="module")
def layout() -> TableLayout:
    """Four garments: No.7 at the bottom under all, No.9 and No.1 side by side on it, No.11
    on top of those two."""
    return random_table(POOL, 4, 3)


@pytest.fixture(scope="module")
def shot(layout: TableLayout, rig: StereoRig) -> TableShot:
    return layout.render(rig, hand_table_pose(rig), rng=5)


def _by_instance(shot: TableShot) -> dict[int, GarmentTruth]:
    return {g.instance: g for g in shot.garments}


def _uncovered_share(layout: TableLayout, instance: int) -> float:
    """Share of a garment's footprint that the footprints of the garments above it leave."""
    prints = {g.instance: footprint(g.garment.texture, g.T_table_garment)
              for g in layout.garments}
    mine = layout.garment(instance)
    above = union([prints[g.instance] for g in layout.garments if g.layer > mine.layer])
    own = prints[instance]
    assert own is not None
    return 1.0 - (own.overlap_mm2(above) if above is not None else 0.0) / own.area_mm2


# --- the render: one pass tracks every garment -----------------------------------------------


def test_tracking_several_layers_gives_what_tracking_each_alone_gives(layout: TableLayout,
                                                                      rig: StereoRig) -> None:
    items, index = layout._items()
    T = hand_table_pose(rig)
    many = render_view_linear(rig.cam1, T, layout.surface, items, track=index[:2])
    assert many.coverage is None and many.visible is None and len(many.visibles) == 2
    for k, at in enumerate(index[:2]):
        one = render_view_linear(rig.cam1, T, layout.surface, items, track=at)
        assert one.coverages == () and one.visibles == ()
        assert one.coverage is not None and one.visible is not None
        np.testing.assert_array_equal(many.coverages[k], one.coverage)
        np.testing.assert_array_equal(many.visibles[k], one.visible)
        np.testing.assert_array_equal(many.image, one.image)
    with pytest.raises(ValueError, match="track"):
        render_view_linear(rig.cam1, T, layout.surface, items, track=[0, 0])


# --- truth of a rendered table ---------------------------------------------------------------


def test_the_fixture_is_a_pile(shot: TableShot) -> None:
    truth = _by_instance(shot)
    assert [g.layer for g in shot.garments] == [0, 1, 1, 2]
    assert truth[0].covered_by == (1, 2, 3)
    assert truth[1].covered_by == truth[2].covered_by == (3,)
    assert truth[3].covered_by == ()
    assert shot.pick_first is not None and shot.pick_first.instance == 3


def test_visible_fractions_agree_with_the_footprints(layout: TableLayout,
                                                     shot: TableShot) -> None:
    for g in shot.garments:
        expected = _uncovered_share(layout, g.instance)
        assert g.visible_fraction[0] == pytest.approx(expected, abs=0.03), g.instance
        assert g.visible_fraction[1] == pytest.approx(expected, abs=0.03), g.instance
        if g.covered_by:
            assert max(g.visible_fraction) < 0.99
        else:
            assert min(g.visible_fraction) > 0.995


def test_poses_lie_on_their_layers(layout: TableLayout, shot: TableShot, rig: StereoRig) -> None:
    T_table_cam1 = np.linalg.inv(hand_table_pose(rig))
    for g in shot.garments:
        T_table_model = T_table_cam1 @ g.T_cam1_model
        assert T_table_model[2, 3] == pytest.approx(-g.layer * CLOTH_THICKNESS_MM, abs=1e-9)
        np.testing.assert_allclose(T_table_model,
                                   layout.garment(g.instance).T_table_garment, atol=1e-9)


def test_the_truth_entry_keeps_the_single_garment_keys(shot: TableShot) -> None:
    entry = json.loads(json.dumps(shot.to_json_dict()))
    first = shot.pick_first
    assert first is not None
    assert entry["model"] == first.model and entry["table"] == 4
    np.testing.assert_allclose(entry["T_cam1_model"], first.T_cam1_model)
    assert [set(g) for g in entry["garments"]] == [
        {"instance", "model", "T_cam1_model", "layer", "visible_fraction", "covered_by",
         "covered_by_instances"}] * 4
    assert entry["garments"][0]["covered_by_instances"] == [1, 2, 3]
    names = {g["instance"]: g["model"] for g in entry["garments"]}
    assert entry["garments"][0]["covered_by"] == [names[i] for i in (1, 2, 3)]


@pytest.mark.parametrize("n", [2, 3, 5, 6])
def test_random_piles_are_settled_and_in_view(n: int, rig: StereoRig) -> None:
    T_cam1_table = hand_table_pose(rig)
    for seed in range(4):
        layout = random_table(POOL, n, seed)
        covers = layout.covered_by()
        assert sorted(layout.instances) == list(range(n))
        for k, g in enumerate(layout.garments):
            over = covers[g.instance][0]
            assert all(layout.garment(h).layer > g.layer for h in over)
            # in stacking order: what lies on a garment comes after it
            assert all(layout.instances.index(h) > k for h in over)
            under = [h for h in layout.garments if g.instance in covers[h.instance][0]]
            assert g.layer == 1 + max((h.layer for h in under), default=-1)
            for camera, T in ((rig.cam1, np.eye(4)), (rig.cam2, rig.T_cam2_cam1)):
                assert _in_image_fraction(camera, T @ T_cam1_table @ g.T_table_garment,
                                          g.garment.texture) == 1.0


def test_piles_mix_free_partly_and_mostly_hidden_garments() -> None:
    shares = [_uncovered_share(layout, g.instance)
              for seed in range(12) for layout in [random_table(POOL, 4, 100 + seed)]
              for g in layout.garments]
    shares_arr = np.asarray(shares)
    assert 0.2 < np.mean(shares_arr > 0.995) < 0.5
    assert 0.2 < np.mean((shares_arr >= 0.5) & (shares_arr <= 0.995)) < 0.6
    assert 0.05 < np.mean(shares_arr < 0.5) < 0.4


def test_one_model_twice_and_never_when_not_allowed() -> None:
    twice = random_table(POOL[:1], 2, 0)
    assert [g.model for g in twice.garments] == ["No.1", "No.1"]
    with pytest.raises(ValueError, match="garments"):
        random_table(POOL[:1], 2, 0, same_model_allowed=False)
    for seed in range(6):
        models = [g.model for g in random_table(POOL, 6, seed,
                                                same_model_allowed=False).garments]
        assert len(set(models)) == 6


@pytest.mark.parametrize("n", [0, 1, 7])
def test_a_table_size_out_of_range_is_refused(n: int) -> None:
    with pytest.raises(ValueError, match="n: expected an integer from 2 to 6"):
        random_table(POOL, n, 0)


def test_the_same_seed_gives_the_same_images(rig: StereoRig) -> None:
    a, info_a = simulate_table(POOL, 3, rig, None, 11)
    b, info_b = simulate_table(POOL, 3, rig, None, 11)
    np.testing.assert_array_equal(a.right_bgr, b.right_bgr)
    np.testing.assert_array_equal(a.left_bgr, b.left_bgr)
    assert a.to_json_dict() == b.to_json_dict() and info_a == info_b
    c, _ = simulate_table(POOL, 3, rig, None, 12)
    assert not np.array_equal(a.right_bgr, c.right_bgr)


def test_distractors_on_the_pile_are_in_the_truth(rig: StereoRig) -> None:
    shot, _ = simulate_table(POOL, 3, rig, parse_conditions("distractors+overlap"), 2)
    truth = _by_instance(shot)
    kinds = [d["kind"] for d in shot.distractors]
    assert kinds.count("garment") >= 2
    on_pile = [d for d in shot.distractors if d["covers"]]
    assert on_pile, "the overlap condition lays a foreign garment over a garment"
    for k, d in enumerate(shot.distractors):
        for instance in d["covers"]:
            assert d["layer"] > truth[instance].layer
            assert k in truth[instance].covered_by_distractors
    first = shot.pick_first
    assert first is not None and first.covered_by == ()


# --- the cell's view: take one away, move one, look again ------------------------------------


def test_without_the_top_garment_the_ones_under_it_are_free(layout: TableLayout,
                                                            rig: StereoRig) -> None:
    after = layout.without(3)
    assert after.instances == (0, 1, 2)
    shot = after.render(rig, hand_table_pose(rig), rng=5)
    truth = _by_instance(shot)
    assert truth[1].covered_by == truth[2].covered_by == () and truth[0].covered_by == (1, 2)
    assert min(truth[1].visible_fraction + truth[2].visible_fraction) > 0.995
    assert truth[1].layer == truth[2].layer == 1
    with pytest.raises(ValueError, match="no garment 3"):
        after.without(3)


def test_without_the_bottom_garment_the_pile_falls(layout: TableLayout) -> None:
    after = layout.without(0)
    assert {g.instance: g.layer for g in after.garments} == {1: 0, 2: 0, 3: 1}
    for g in after.garments:
        assert g.T_table_garment[2, 3] == pytest.approx(-g.layer * CLOTH_THICKNESS_MM)


def test_an_empty_table_has_nothing_to_pick(layout: TableLayout, rig: StereoRig) -> None:
    empty = layout
    for instance in layout.instances:
        empty = empty.without(instance)
    shot = empty.render(rig, hand_table_pose(rig), rng=5)
    assert shot.garments == () and shot.pick_first is None
    entry = shot.to_json_dict()
    assert entry["model"] is None and entry["T_cam1_model"] is None and entry["table"] == 0


def test_a_moved_garment_is_seen_where_it_now_lies(layout: TableLayout, rig: StereoRig) -> None:
    # The bottom garment pulled towards a corner of the view: it still lies under two of the
    # others, and No.1 (which lay on it only) falls onto the table.
    corner = garment_placement(-150.0, -110.0, 10.0)
    moved = layout.moved(0, corner)
    assert {g.instance: g.layer for g in moved.garments} == {0: 0, 1: 1, 2: 0, 3: 2}
    assert moved.covered_by()[0] == ((1, 3), ())
    T_cam1_table = hand_table_pose(rig)
    truth = _by_instance(moved.render(rig, T_cam1_table, rng=5))
    np.testing.assert_allclose(truth[0].T_cam1_model, T_cam1_table @ corner, atol=1e-9)
    for g in moved.garments:
        assert truth[g.instance].visible_fraction[0] == pytest.approx(
            _uncovered_share(moved, g.instance), abs=0.03)
    # Put down over the pile instead, it hides others and nothing hides it.
    top = layout.moved(0, corner, on_top=True)
    assert top.instances[-1] == 0 and top.covered_by()[0] == ((), ())
    assert {g.instance: g.layer for g in top.garments} == {1: 0, 2: 0, 3: 1, 0: 2}
    assert top.garment(0).T_table_garment[2, 3] == pytest.approx(-2 * CLOTH_THICKNESS_MM)


def test_a_move_must_be_a_rigid_transform(layout: TableLayout) -> None:
    with pytest.raises(ValueError, match="T_table_garment"):
        layout.moved(0, np.eye(3))
    with pytest.raises(ValueError, match="instance"):
        layout.moved(9, np.eye(4))


# --- photomodel simulate --table --------------------------------------------------------------


def test_simulate_table_writes_a_dataset_with_the_pile_truth(capsys, tmp_path: Path) -> None:
    out = tmp_path / "ds"
    code = main(["simulate", "--table", "2", "--garments", "No.3,No.6", "--seed", "3",
                 "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    assert "1 scene(s)" in capsys.readouterr().out
    names = {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()}
    assert {"stereo.yaml", "model_camera.yaml", "truth.json", "models/No.3/photo.bmp",
            "models/No.3/background.bmp", "models/No.6/photo.bmp",
            "scenes/table2_0000/right.png", "scenes/table2_0000/left.png"} <= names
    truth = json.loads((out / "truth.json").read_text())
    entry = truth["table2_0000"]
    assert entry["table"] == 2 and entry["condition"] == "paper"
    assert len(entry["garments"]) == 2
    assert entry["model"] in ("No.3", "No.6")
    first = next(g for g in entry["garments"] if g["instance"] == entry["pick_first"])
    assert first["covered_by"] == [] and entry["T_cam1_model"] == first["T_cam1_model"]
    assert json.loads((out / "dataset.json").read_text())["table"] == 2
    again = write_dataset(tmp_path / "again", ["No.3", "No.6"], scenes=1, seed=3, table=2)
    for name in ("right.png", "left.png"):
        assert ((again.out / "scenes" / "table2_0000" / name).read_bytes()
                == (out / "scenes" / "table2_0000" / name).read_bytes())


@pytest.mark.parametrize("value, message", [
    ("0", "--table: expected an integer from 2 to 6, got 0"),
    ("7", "--table: expected an integer from 2 to 6, got 7"),
    ("two", "--table: invalid int value: 'two'"),
])
def test_a_bad_table_size_is_one_error_line(capsys, tmp_path: Path, value: str,
                                            message: str) -> None:
    out = tmp_path / "ds"
    try:
        code = main(["simulate", "--table", value, "--out", str(out)])
    except SystemExit as stop:  # argparse's own errors
        code = int(stop.code or 0)
    err = capsys.readouterr().err
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("photomodel: error: "), err
    assert message in lines[0] and "Traceback" not in err
    assert not out.exists()
