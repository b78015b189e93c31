"""Rooms as people see them (issue 29), measured: the segmentation scored against the
labelled scans' truth (tests/buildings/labelled_scans.py) with Bormann et al.'s
per-room recall and precision, on a few maps of different kinds, bare and furnished;
and rooms named by the operator's marks. bench/segmentation.py scores all 22 maps."""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest

from giraff_console.cli.main import main
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.grid import FREE, OCCUPIED
from giraff_console.planning.room_marks import MarkProblem
from giraff_console.planning.room_openings import MAX_DOOR_M
from giraff_console.planning.room_segmentation import MarkError, segment_rooms
from tests.buildings.labelled_layouts import FULL, MAPS, layout
from tests.buildings.labelled_scans import labelled_scan
from tests.planning.scanned_rooms import write_scanned_map
from tests.planning.segmentation_scores import score, segment_and_score

# The issue's bar: with furniture recall >= 90 % and precision >= 95 %; without, 97 / 96.
TARGETS = {False: (97.0, 96.0), True: (90.0, 95.0)}
SUBSET = [("care-wing", 1), ("office", 0), ("house", 2), ("l-hall", 1), ("dining-hall", 0),
          ("suite", 1), ("corridor", 0)]  # fmt: skip


@pytest.mark.parametrize("furnished", [False, True], ids=["bare", "furnished"])
def test_the_segmentation_meets_the_issues_bar_on_a_subset_of_the_truth(furnished):
    scores = [segment_and_score(labelled_scan(*which), furnished)[0] for which in SUBSET]
    recall = float(np.mean([s.recall for s in scores]))
    precision = float(np.mean([s.precision for s in scores]))
    least_recall, least_precision = TARGETS[furnished]
    assert recall >= least_recall and precision >= least_precision, (recall, precision)
    # Furniture makes no rooms: a segment or two too many at most (measured: 69 for 68
    # rooms furnished, 68 bare; 74 furnished before a corridor's cuts needed jambs).
    assert sum(s.segments for s in scores) <= 1.05 * sum(s.rooms for s in scores), scores


def test_the_truth_has_at_least_20_maps_of_every_kind_asked_for():
    assert len(MAPS) >= 20
    kinds = {labelled_scan(*which).kind for which in MAPS}
    assert kinds == {"care wing", "office", "house", "L hall", "U hall", "dining hall",
                     "rooms with wide openings", "corridor with alcoves"}  # fmt: skip


@pytest.mark.parametrize("which", SUBSET[:4])
def test_the_two_versions_differ_by_furniture_only(which):
    scan = labelled_scan(*which)
    bare, furnished = scan.grid(False), scan.grid(True)
    assert bare.shape == furnished.shape == scan.truth.shape
    added = (furnished.cells == OCCUPIED) & (bare.cells == FREE)
    # Furniture stands on floor: a tenth to a half of a building's floor is furnished.
    floor = scan.truth > 0
    assert 0.02 < added[floor].mean() < 0.5
    assert not added[~floor & (bare.cells != FREE)].any()


def test_openings_are_labelled_by_the_stated_rule():
    for kind, seed in MAPS:
        plan = layout(kind, seed)
        for opening in plan.openings:
            one_room = plan.spaces[opening.a].room == plan.spaces[opening.b].room
            assert one_room == (opening.width == FULL or opening.width > MAX_DOOR_M)


def test_the_score_counts_unlabelled_floor_against_recall_and_mixed_segments_against_precision():
    truth = np.array([[1, 1, 1, 1, 2, 2, 2, 2]])
    floor = np.ones(truth.shape, bool)
    assert score(truth, truth, floor) == (100.0, 100.0)
    assert score(truth, np.array([[1, 1, 0, 0, 2, 2, 2, 2]]), floor) == (75.0, 100.0)
    assert score(truth, np.array([[1, 1, 1, 1, 1, 1, 2, 2]]), floor) == pytest.approx((75, 250 / 3))


def test_marked_rooms_take_their_names_and_the_rest_stay_room_n():
    scan = labelled_scan("house", 0)
    marks = [("kitchen", scan.point_in("kitchen")), ("living", scan.point_in("living"))]
    found = segment_rooms(scan.grid(True), marks=marks)
    ids = [room.id for room in found.rooms]
    assert "kitchen" in ids and "living" in ids
    label = {room.id: room.label for room in found.rooms}
    for name, (x, y) in marks:
        assert found.labels[found.grid.cell_of(x, y)] == label[name]
    assert sorted(i for i in ids if i.startswith("room-")) == [
        f"room-{n}" for n in range(1, len(ids) - 1)
    ]
    assert any("kitchen" in door.between for door in found.doors)


@pytest.mark.parametrize(("marks", "problem"), [
    ([("kitchen", "kitchen"), ("kitchen", "living")], MarkProblem.DUPLICATE),
    ([("the kitchen", "kitchen")], MarkProblem.BAD_NAME),
    ([("kitchen", "kitchen"), ("pantry", "kitchen")], MarkProblem.SAME_ROOM),
    ([("garden", None)], MarkProblem.OFF_ROOMS),
])  # fmt: skip
def test_marks_that_cannot_name_rooms_are_refused_each_with_its_problem(marks, problem):
    scan = labelled_scan("house", 0)
    at = {None: (scan.origin[0] + 0.2, scan.origin[1] + 0.2)}
    given = [(name, at[room] if room is None else scan.point_in(room)) for name, room in marks]
    with pytest.raises(MarkError) as error:
        segment_rooms(scan.grid(False), marks=given)
    assert [issue.problem for issue in error.value.issues] == [problem]
    assert marks[-1][0] in str(error.value)


def rooms_command(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["floorplan", "rooms", *args])
    return code, out.getvalue(), err.getvalue()


def test_floorplan_rooms_names_the_marked_rooms_and_refuses_a_bad_mark(tmp_path):
    scan = labelled_scan("house", 1)
    path = write_scanned_map(tmp_path, image=scan.furnished, origin=scan.origin)
    (x, y), (bx, by) = scan.point_in("kitchen"), scan.point_in("bathroom")
    out = tmp_path / "p.yaml"
    code, _, err = rooms_command(str(path), str(out), "--mark", f"kitchen={x},{y}",
                                       "--mark", f"bathroom={bx},{by}")  # fmt: skip
    assert code == 0, err
    plan = load_floorplan(out)
    assert {"kitchen", "bathroom"} <= plan.rooms.keys() and "Traceback" not in err
    for bad in (f"kitchen={x}", f"sink={x},{y}"):
        code, _, err = rooms_command(str(path), str(tmp_path / "q.yaml"), "--mark", bad,
                                     "--mark", f"kitchen={x},{y}")  # fmt: skip
        assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
        assert not (tmp_path / "q.yaml").exists()
