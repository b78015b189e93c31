"""Patrol files: whatever their bytes, load_patrol gives a Patrol or a PatrolError that
names the file, never a traceback (issue 12)."""

from __future__ import annotations

import yaml
from hypothesis import given

from giraff_console.missions.patrol import PatrolError, load_patrol
from tests.fuzz.inputs import FUZZ, file_cases, replaced
from tests.fuzz.test_route_files import dump

# A patrol as routes/README.md describes one: routes, a room, a followed route.
SEED = b"""\
rounds: 3
snapshots: true
stops:
- {route: hall-to-kitchen, dwell: 10}
- {route: kitchen-to-hall, dwell: 5, follow: true}
- {room: day-room, dwell: 30.5}
"""


def test_the_seed_is_a_good_patrol(folder):
    path = folder / "seed.patrol.yaml"
    path.write_bytes(SEED)
    assert [stop.place for stop in load_patrol(path).stops][-1] == "day-room"


def test_a_patrol_of_a_billion_rounds_is_refused_where_it_is_written(folder):
    path = folder / "many.patrol.yaml"
    path.write_bytes(SEED.replace(b"rounds: 3", b"rounds: 1000000000"))
    try:
        load_patrol(path)
    except PatrolError as error:
        assert str(error).startswith(f"{path}:1: rounds should be a whole number from 1 to")
    else:
        raise AssertionError("a billion rounds loaded")


@FUZZ
@given(data=file_cases(SEED, replaced(yaml.safe_load(SEED), dump)))
def test_any_bytes_give_a_patrol_or_a_patrol_error(folder, data):
    path = folder / "fuzzed.patrol.yaml"
    path.write_bytes(data)
    try:
        load_patrol(path)
    except PatrolError as error:
        assert str(error).startswith(f"{path}:")
