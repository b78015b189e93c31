"""Renaming a room of a floor plan, in memory and in its file (thesis §2.6.3).

"In each room, the robot would be told the name of the room the robot is in" (§2.6.3):
a plan made from a scan names its rooms `room-1`, `room-2`, ... (`floorplan rooms`), and
the operator gives them their real names from the console, `name room-3 kitchen`, or
`mark kitchen` where the robot stands. The new name is the room's id from then on:
`go kitchen` works, and the plan file says `kitchen:`.

The file is edited as text, only where the old id is written (the room's key, the doors'
`between`, `start`), so that its comments and layout stay as the operator left them.
Door ids are not changed: the simulated building and patrols may know a door by its id.
The new text must pass `floorplan check` before it replaces the file, in one rename, so
that a failure at any point leaves the file as it was.
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import replace
from pathlib import Path

import yaml

from giraff_console.planning.floorplan import (
    FloorPlan,
    FloorPlanError,
    is_id,
    load_floorplan,
)

# The example plans that ship inside the package: an upgrade would overwrite a rename, and
# every user of the installation shares them.
SHIPPED = Path(__file__).resolve().parents[1] / "floorplans"


class RenameError(ValueError):
    """A rename that cannot be done; says why, for the operator."""


def check_rename(plan: FloorPlan, old: str, new: str) -> None:
    """RenameError unless `old` is a room of `plan` and `new` a name it could take."""
    if old not in plan.rooms:
        raise RenameError(f"no room {old!r}; rooms: {', '.join(sorted(plan.rooms))}")
    if not is_id(new):
        raise RenameError(f"{new!r} cannot be a room's name: 1 to 64 letters, digits, - and _ "
                          "(it is typed, as in `go kitchen`)")  # fmt: skip
    if new in plan.rooms:
        raise RenameError(f"there is a room {new!r} already")
    if any(door.id == new for door in plan.doors):
        raise RenameError(f"there is a door {new!r}: a room and a door cannot share a name")


def renamed(plan: FloorPlan, old: str, new: str) -> FloorPlan:
    """`plan` with room `old` called `new`; RenameError if it cannot be."""
    check_rename(plan, old, new)
    room = plan.rooms[old]
    # A room without a label of its own is shown by its id, so its label goes with it.
    room = replace(room, id=new, label=new if room.label == old else room.label)
    rooms = {new if room_id == old else room_id: room if room_id == old else other
             for room_id, other in plan.rooms.items()}  # fmt: skip
    doors = [
        replace(door, between=(new if door.between[0] == old else door.between[0],
                                new if door.between[1] == old else door.between[1]))
        for door in plan.doors
    ]  # fmt: skip
    start = new if plan.start == old else plan.start
    return replace(plan, rooms=rooms, doors=doors, start=start)


def rename_in_file(plan: FloorPlan, old: str, new: str) -> FloorPlan:
    """Rename room `old` to `new` in `plan`'s file and return the plan read back from it.
    RenameError if it cannot be (the file is then as it was), OSError if the file
    cannot be written."""
    check_rename(plan, old, new)
    path = plan.path
    if path.resolve().parent == SHIPPED:
        raise RenameError(f"{path.name} is the example that comes with the console and is not "
                          "renamed: copy it, and start with --floorplan COPY")  # fmt: skip
    text = path.read_text(encoding="utf-8")
    spans = _spans_naming(text, old)
    if not spans:
        raise RenameError(f"{path} does not name room {old!r} any more: was it edited?")
    # A name YAML would read as something else (101, true, 1e3) is quoted.
    written = new if yaml.safe_load(new) == new else f"'{new}'"
    for start, end in sorted(spans, reverse=True):
        text = text[:start] + written + text[end:]
    with tempfile.NamedTemporaryFile(
        "w",
        encoding="utf-8",
        dir=path.parent,
        prefix=f".{path.name}.",
        suffix=".yaml",
        delete=False,
    ) as trial:
        trial.write(text)
    trial_path = Path(trial.name)
    try:
        # The copy is read back as the plan it must be before it replaces the file.
        read_back = load_floorplan(trial_path)
        if read_back.rooms.keys() != renamed(plan, old, new).rooms.keys():
            raise RenameError(f"{path}: the renamed plan did not read back as it should")
        os.chmod(trial_path, path.stat().st_mode & 0o777)
        os.replace(trial_path, path)
    except FloorPlanError as error:
        raise RenameError(f"not renamed, the plan would not load: {error}") from None
    finally:
        trial_path.unlink(missing_ok=True)
    return replace(read_back, path=path)


def _spans_naming(text: str, room: str) -> list[tuple[int, int]]:
    """Where in `text` room id `room` is written: the room's key under `rooms`, each
    door's `between`, and `start`; as (start, end) character offsets."""
    root = yaml.compose(text, Loader=yaml.SafeLoader)
    if not isinstance(root, yaml.MappingNode):
        return []
    spans = []

    def names(node: yaml.Node) -> bool:
        return isinstance(node, yaml.ScalarNode) and node.value == room

    def span(node: yaml.Node) -> tuple[int, int]:
        return node.start_mark.index, node.end_mark.index

    for key, value in root.value:
        if key.value == "rooms" and isinstance(value, yaml.MappingNode):
            spans += [span(room_key) for room_key, _ in value.value if names(room_key)]
        elif key.value == "doors" and isinstance(value, yaml.SequenceNode):
            for door in value.value:
                if not isinstance(door, yaml.MappingNode):
                    continue
                for door_key, between in door.value:
                    if door_key.value == "between" and isinstance(between, yaml.SequenceNode):
                        spans += [span(end) for end in between.value if names(end)]
        elif key.value == "start" and names(value):
            spans.append(span(value))
    return spans
