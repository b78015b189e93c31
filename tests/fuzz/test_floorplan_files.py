"""Floor plans: whatever their bytes, load_floorplan gives a plan or a FloorPlanError,
never a traceback (issue 12)."""

from __future__ import annotations

import math
import shutil
from importlib.resources import files

import yaml
from hypothesis import given

from giraff_console.planning.floorplan import FloorPlanError, load_floorplan
from giraff_console.planning.landmarks import IN_FRONT_M, inside
from tests.fuzz.inputs import FUZZ, file_cases, replaced
from tests.fuzz.test_route_files import dump

EXAMPLES = files("giraff_console") / "floorplans"
PLAN = yaml.safe_load((EXAMPLES / "care-home.yaml").read_bytes())


# The example cut down to the rooms nearest its start, the doors between them and its grid: the
# whole of it takes ten times longer to read, and has nothing these lack.
def _near_start(count: int) -> list[str]:
    """The start room and the rooms nearest it through doors, `count` in all."""
    kept = [PLAN["start"]]
    for door in PLAN["doors"] * count:
        a, b = door["between"]
        if len(kept) < count and (a in kept) != (b in kept):
            kept.append(b if a in kept else a)
    return kept


def ahead(marker: dict) -> tuple[float, float]:
    """A point in front of a marker, in the room it faces into."""
    (x, y), facing = marker["at"], math.radians(marker["facing"])
    return x + IN_FRONT_M * math.cos(facing), y + IN_FRONT_M * math.sin(facing)


ROOMS = {room: PLAN["rooms"][room] for room in _near_start(6)}
DOORS = [door for door in PLAN["doors"] if set(door["between"]) <= set(ROOMS)]
# The markers on those rooms' walls, facing into them: the rest hang on walls the seed lacks.
MARKERS = [
    marker
    for marker in PLAN["landmarks"]["markers"]
    if any(inside(ahead(marker), room["outline"]) for room in ROOMS.values())
]
LANDMARKS = {**PLAN["landmarks"], "markers": MARKERS}
SEED = yaml.safe_dump(
    {**PLAN, "rooms": ROOMS, "doors": DOORS, "landmarks": LANDMARKS}, sort_keys=False
).encode()


def test_the_seed_is_a_good_floor_plan(folder):
    shutil.copyfile(str(EXAMPLES / "care-home.pgm"), folder / "care-home.pgm")
    path = folder / "seed.yaml"
    path.write_bytes(SEED)
    plan = load_floorplan(path)
    assert len(plan.doors) == len(DOORS) > 2
    assert len(plan.landmarks.markers) == len(MARKERS) > 2 * len(DOORS)


@FUZZ
@given(data=file_cases(SEED, replaced(yaml.safe_load(SEED), dump)))
def test_any_bytes_give_a_floor_plan_or_its_problems(folder, data):
    # The example's grid image beside it, so that mutations reach the grid checks.
    image = folder / "care-home.pgm"
    if not image.exists():
        shutil.copyfile(str(EXAMPLES / "care-home.pgm"), image)
    path = folder / "fuzzed.yaml"
    path.write_bytes(data)
    try:
        load_floorplan(path)
    except FloorPlanError as error:
        # check_floorplan reads through the same _read: its list is this one.
        assert error.problems and all(problem.path == path for problem in error.problems)
