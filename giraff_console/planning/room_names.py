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
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import yaml

from giraff_console.file_limits import read_bounded
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
    # A plan reached through a link is renamed where it is, and the link stays.
    path = plan.path.resolve()
    if path.parent == SHIPPED:
        raise RenameError(f"{path.name} is the example that comes with the console and is not "
                          "renamed: copy it, and start with --floorplan COPY")  # fmt: skip
    text = read_bounded(path).decode("utf-8")  # its line endings kept
    edits = _edits(text, old, new)
    if not any(end > start for start, end, _ in edits):
        raise RenameError(f"{path} does not name room {old!r} any more: was it edited?")
    for start, end, replacement in sorted(edits, reverse=True):
        text = text[:start] + replacement + text[end:]
    with tempfile.NamedTemporaryFile(
        "w",
        encoding="utf-8",
        newline="",
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
        expected = renamed(plan, old, new)
        if read_back.rooms.keys() != expected.rooms.keys() or read_back.doors != expected.doors:
            raise RenameError(f"{path}: the renamed plan did not read back as it should")
        os.chmod(trial_path, path.stat().st_mode & 0o777)
        os.replace(trial_path, path)
    except FloorPlanError as error:
        problems = "; ".join(problem.message for problem in error.problems)
        raise RenameError(f"not renamed, {path} would not load: {problems}") from None
    finally:
        trial_path.unlink(missing_ok=True)
    return replace(read_back, path=plan.path)


def _written(name: str) -> str:
    """`name` as YAML text: quoted if YAML would read it as something else (101, true)."""
    return name if yaml.safe_load(name) == name else f"'{name}'"


def _edits(text: str, room: str, new: str) -> list[tuple[int, int, str]]:
    """What to change in `text` to call room `room` `new`, as (start, end, replacement)
    character ranges: the room's key under `rooms`, each door's `between`, and `start`.
    A door that joins the room and has no `id` takes its id from its rooms' names, so
    it is given the one it had (the simulated building and patrols know it by it)."""
    if any(isinstance(token, yaml.AnchorToken | yaml.AliasToken)
           for token in yaml.scan(text, Loader=yaml.SafeLoader)):  # fmt: skip
        raise RenameError("the plan file uses YAML anchors (&name, *name): rename the room in "
                          "it by hand")  # fmt: skip
    root = yaml.compose(text, Loader=yaml.SafeLoader)
    if not isinstance(root, yaml.MappingNode):
        return []
    newline = "\r\n" if "\r\n" in text else "\n"
    edits = []

    def names(node: yaml.Node) -> bool:
        return isinstance(node, yaml.ScalarNode) and node.value == room

    def renaming(node: yaml.Node) -> tuple[int, int, str]:
        return node.start_mark.index, node.end_mark.index, _written(new)

    for key, value in root.value:
        if key.value == "rooms" and isinstance(value, yaml.MappingNode):
            edits += [renaming(room_key) for room_key, _ in value.value if names(room_key)]
        elif key.value == "doors" and isinstance(value, yaml.SequenceNode):
            for door in value.value:
                if isinstance(door, yaml.MappingNode):
                    edits += _door_edits(text, door, names, renaming, newline)
        elif key.value == "start" and names(value):
            edits.append(renaming(value))
    return edits


def _door_edits(text: str, door: yaml.MappingNode, names: Callable[[yaml.Node], bool],
                renaming: Callable[[yaml.Node], tuple[int, int, str]],
                newline: str) -> list[tuple[int, int, str]]:  # fmt: skip
    fields = {key.value: value for key, value in door.value}
    between = fields.get("between")
    if not isinstance(between, yaml.SequenceNode):
        return []
    ends = [end for end in between.value if names(end)]
    edits = [renaming(end) for end in ends]
    if not ends or "id" in fields:
        return edits
    # The id the loader gave it: its rooms' ids joined by '-'.
    kept = f"id: {_written('-'.join(str(end.value) for end in between.value))}"
    if door.flow_style:
        closing = door.end_mark.index - 1  # at its '}'
        return [*edits, (closing, closing, f", {kept}")]
    indent = " " * door.value[0][0].start_mark.column
    after = door.value[-1][1].end_mark.index
    if after > 0 and text[after - 1] != "\n":
        # After the end of the last line, past any comment on it.
        line_end = text.find("\n", after)
        if line_end < 0:
            return [*edits, (len(text), len(text), f"{newline}{indent}{kept}{newline}")]
        after = line_end + 1
    return [*edits, (after, after, f"{indent}{kept}{newline}")]
