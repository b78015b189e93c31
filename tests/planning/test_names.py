"""A name the operator typed that is not there (planning/names.py)."""

from __future__ import annotations

from giraff_console.planning.names import LISTED, no_such

ROOMS = ["kitchen", "lobby", "dining-room", *(f"room-{n}" for n in range(101, 131))]


def test_a_misspelt_name_gets_the_one_meant():
    assert no_such("room", "kitchn", ROOMS) == "no room called 'kitchn': did you mean kitchen?"
    assert no_such("room", "Kitchen", ROOMS).endswith("did you mean kitchen?")
    assert no_such("room", "KITCHEN", ROOMS).endswith("did you mean kitchen?")
    assert no_such("room", "dinning-room", ROOMS).endswith("did you mean dining-room?")


def test_at_most_three_are_suggested_the_likest_first_then_in_order():
    said = no_such("room", "room-1o1", ROOMS)
    assert said == "no room called 'room-1o1': did you mean room-101 or room-110 or room-111?"


def test_a_name_like_none_lists_a_few_or_counts_many_and_says_where():
    few = ROOMS[:LISTED]
    assert (
        no_such("room", "attic", few) == f"no room called 'attic' (rooms: {', '.join(sorted(few))})"
    )
    many = no_such("room", "attic", ROOMS, "`floorplan show` draws them")
    assert many == (f"no room called 'attic', nor any like it among the {len(ROOMS)} rooms "
                    "(`floorplan show` draws them)")  # fmt: skip
    assert no_such("route", "night", []) == "no route called 'night': there are none"
