"""Placing markers on a floor plan's walls for the user, and writing them into the file.

`giraff-console floorplan landmarks FILE` puts a marker beside every doorway on both
sides, in each of the two rooms, where the robot sees one as it comes up to the door and
as it leaves through it; then along every wall at least `every` metres long, so that no
long stretch of wall is without one. The walls are the outlines' edges or, in a plan
without outlines, the walls in its grid (marker_faces.py). Markers already in the plan
stay where they are (staff may have put them up): new ones only fill in. The file is
edited as text, so the user's comments and layout survive; only the `landmarks:` block
is written anew.
"""

from __future__ import annotations

import math
import os
import tempfile
from dataclasses import dataclass, replace

import yaml

from giraff_console.camera.marker_reach import STANDARD_SIZE_M
from giraff_console.file_limits import read_bounded
from giraff_console.planning.defaults import DEFAULT_EVERY_M, DEFAULT_FAMILY
from giraff_console.planning.floorplan import (
    Door,
    FloorPlan,
    FloorPlanError,
    Landmarks,
    Marker,
    Point,
    Problem,
    load_floorplan,
)
from giraff_console.planning.landmarks import (
    id_count,
    marker_poses,
    marker_walls,
    paper_side,
    where_it_goes,
)
from giraff_console.planning.marker_faces import Face, marker_faces
from giraff_console.planning.stop_markers import place_for_stops, size_for_stops

# Centre 1.10 m above the floor: below the camera in the robot's head (1.3 m), so a
# marker near the robot is still in view, and above chairs and handrails.
DEFAULT_HEIGHT_M = 1.10
# A doorway's marker is at most this far from it (its centre from the doorway's edge).
BESIDE_DOOR_M = 1.0


@dataclass(frozen=True)
class Placement:
    landmarks: Landmarks
    beside_doors: int
    along_walls: int
    for_stops: int
    notes: list[str]

    @property
    def added(self) -> int:
        return self.beside_doors + self.along_walls + self.for_stops


def place_markers(
    plan: FloorPlan,
    every: float = DEFAULT_EVERY_M,
    size: float | None = None,
    height: float = DEFAULT_HEIGHT_M,
    family: str = DEFAULT_FAMILY,
) -> Placement:
    """The plan's markers with new ones beside its doorways, along its long walls and
    where a room's stop would read too few (stop_markers.py): on its outlines' edges, or
    without outlines its grid's walls (marker_faces.py). The plan's own family and size
    win over those given; without either, the size is the least that every stop reads.
    ValueError for a plan with no walls, or more markers than the family has ids;
    OSError if its grid cannot be read."""
    if not (math.isfinite(every) and every > 0):
        raise ValueError("markers are placed every so many metres: --every must be positive")
    if size is not None and not (math.isfinite(size) and size > 0):
        raise ValueError("a marker's size is in metres: --size must be positive")
    existing = plan.landmarks.markers if plan.landmarks else ()
    sight = marker_walls(plan).segments
    notes: list[str] = []
    if plan.landmarks is not None:
        family, size = plan.landmarks.family, plan.landmarks.size
    elif size is None:
        standard, _ = marker_faces(plan, paper_side(family, STANDARD_SIZE_M))
        size = size_for_stops(plan, standard, sight)
        if size > STANDARD_SIZE_M:
            notes.append(f"markers are {size:g} m across, not the usual {STANDARD_SIZE_M:g} "
                         "m, so that every room's stop can read them; print them at that "
                         "size, or give --size")  # fmt: skip
    faces, doorways = marker_faces(plan, paper_side(family, size))
    for marker in existing:
        for face in faces:
            if face.holds(marker):
                face.taken.append(face.position(marker.at))
    added: list[tuple[Face, float]] = []
    for door in doorways:
        for room_id in door.between:
            place = _beside(door, [face for face in faces if room_id in face.rooms])
            if place is None:
                if any(room_id in face.rooms for face in faces):
                    notes.append(f"no room for a marker beside door {door.id!r} in {room_id!r}")
                continue
            if place[1] is not None:
                place[0].taken.append(place[1])
                added.append((place[0], place[1]))
    beside_doors = len(added)
    for face in faces:
        for t in _along(face, every) if face.wall else []:
            added.append((face, t))
    along_walls = len(added) - beside_doors
    placed = marker_poses(plan)
    placed.update({-1 - i: face.pose(t) for i, (face, t) in enumerate(added)})
    for_stops, uncovered = place_for_stops(plan, faces, placed, sight, size)
    added += for_stops
    notes += uncovered
    ids = _new_ids(family, existing, len(added))
    new = [
        Marker(marker_id, _rounded(face.point(t)), height, round(face.facing, 1) % 360)
        for marker_id, (face, t) in zip(ids, added, strict=True)
    ]
    markers = tuple(sorted((*existing, *new), key=lambda marker: marker.id))
    landmarks = Landmarks(family, size, markers)
    return Placement(landmarks, beside_doors, along_walls, len(for_stops), notes)


def _beside(door: Door, faces: list[Face]) -> tuple[Face, float | None] | None:
    """Where a doorway's marker goes in one of its rooms: on the doorway's own wall, to
    the right of it as seen from the room (on the other side if there is no room there),
    else on the room's nearest other wall; (face, None) if one is there already."""
    own = [face for face in faces if face.holds_door(door)]
    half = door.width / 2
    for face in faces:
        for taken in face.taken:
            if (
                abs(taken - face.position(door.at)) - half <= BESIDE_DOOR_M
                if face in own
                else math.dist(face.point(taken), door.at) <= BESIDE_DOOR_M + half
            ):
                return face, None
    for face in own:
        t = face.position(door.at)
        nx, ny = math.cos(math.radians(face.facing)), math.sin(math.radians(face.facing))
        right = 1 if face.along[0] * -ny + face.along[1] * nx > 0 else -1
        for side in (right, -right):
            spot = face.nearest(t + side * half, side, BESIDE_DOOR_M)
            if spot is not None:
                return face, spot
    others = [(face, face.nearest(face.position(door.at)))
              for face in faces if face not in own and face.wall]  # fmt: skip
    spots = [
        (math.dist(face.point(t), door.at), face, t)
        for face, t in others
        if t is not None and math.dist(face.point(t), door.at) <= BESIDE_DOOR_M + half
    ]
    if not spots:
        return None
    _, face, t = min(spots, key=lambda spot: spot[0])
    return face, t


def _along(face: Face, every: float) -> list[float]:
    """Markers for a wall at least `every` long, added until no two neighbours on it are
    more than 1.25 `every` apart and neither corner is more than `every` from one: each
    covers `every` / 2 either side, and a stretch left uncovered must be longer than
    `every` / 4 between two markers, or `every` / 2 at a corner, to get one of its own."""
    if face.length < every - 1e-9:
        return []
    placed: list[float] = []
    reach = every / 2
    for _ in range(math.ceil(4 * face.length / every) + 4):  # each round places one or more
        stretch = _uncovered(face, reach)
        if stretch is None:
            break
        low, high = stretch
        count = max(1, math.floor((high - low) / every + 0.5))
        targets = [low + (k + 0.5) * (high - low) / count for k in range(count)]
        spots = [face.nearest(target, 0, reach) for target in targets]
        if not any(spot is not None for spot in spots):
            spots = [face.nearest((low + high) / 2, 0, reach)]  # _uncovered found room there
        for spot in spots:
            # Each against the markers placed before it in this round, too.
            if spot is not None and face.nearest(spot, 0, 0.0) is not None:
                face.taken.append(spot)
                placed.append(spot)
    return placed


def _uncovered(face: Face, reach: float) -> tuple[float, float] | None:
    """The first stretch of the face more than `reach` from every marker on it that is
    long enough to need one and has room for one."""
    start = 0.0
    for t in [*sorted(face.taken), face.length + reach]:
        low, high = start, min(t - reach, face.length)
        at_corner = low == 0.0 or high == face.length
        long_enough = high - low > (reach if at_corner else reach / 2)
        if long_enough and face.nearest((low + high) / 2, 0, reach) is not None:
            return low, high
        start = max(start, t + reach)
    return None


def _new_ids(family: str, existing: tuple[Marker, ...], count: int) -> list[int]:
    """`count` ids after the plan's highest, then any left free below it."""
    used = {marker.id for marker in existing}
    start = max(used, default=-1) + 1
    ids = [i for i in range(start, id_count(family)) if i not in used][:count]
    ids += [i for i in range(start) if i not in used][: count - len(ids)]
    if len(ids) < count:
        raise ValueError(f"{family} has {id_count(family)} ids, too few for "
                         f"{len(existing) + count} markers: use a larger --every")  # fmt: skip
    return ids


def _rounded(point: Point) -> Point:
    # Millimetres: a marker on a slanting wall moves less than a millimetre off it.
    return round(point[0], 3) + 0.0, round(point[1], 3) + 0.0


# Writing them into the file.


def number(value: float) -> str:
    """A number as a person writes it: 12, 12.4, 1.105; one with more digits (written
    by hand) exactly as it is, so that the plan reads back the same."""
    if round(value, 3) != value:
        return repr(value)
    text = f"{value:.3f}".rstrip("0").rstrip(".")
    return "0" if text == "-0" else text


def landmarks_block(plan: FloorPlan, landmarks: Landmarks) -> str:
    """The `landmarks:` key as YAML text, each marker on one line with where it goes."""
    lines = [
        "landmarks:",
        '  # Fiducial markers on the walls (floorplans/README.md, "Landmarks"). `giraff-console',
        "  # floorplan landmarks` rewrites this block: comments in it are not kept.",
        f"  family: {landmarks.family}",
        f"  size: {number(landmarks.size)}",
        "  markers:",
    ]
    for marker in landmarks.markers:
        place = where_it_goes(plan, marker)
        sigma = "" if marker.sigma is None else (
            f", sigma: [{number(marker.sigma[0])}, {number(marker.sigma[1])}]")  # fmt: skip
        at = f"[{number(marker.at[0])}, {number(marker.at[1])}]"
        line = (f"  - {{id: {marker.id}, at: {at}, height: {number(marker.height)}, "
                f"facing: {number(marker.facing)}{sigma}}}")  # fmt: skip
        lines.append(f"{line}  # {place}" if place else line)
    return "\n".join(lines) + "\n"


def with_landmarks(text: str, block: str) -> str:
    """The plan's text with its `landmarks:` key replaced by `block`, or `block` added at
    the end; everything else as it was. ValueError if the file's top level is not a block
    mapping, which a text edit could not keep intact."""
    node = yaml.compose(text, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))
    if not isinstance(node, yaml.MappingNode) or node.flow_style:
        raise ValueError("its top level is not a block mapping (`key: value` lines), so the "
                         "landmarks cannot be written into it")  # fmt: skip
    for key, value in node.value:
        if isinstance(key, yaml.ScalarNode) and key.value == "landmarks":
            start = text.rfind("\n", 0, key.start_mark.index) + 1
            end = text.find("\n", _last_mark(value))
            end = len(text) if end < 0 else end + 1
            return text[:start] + block + text[end:]
    eol = "\r\n" if "\r\n" in text else "\n"
    if text and not text.endswith("\n"):
        text += eol
    return f"{text}{eol}{block}" if text else block


def _last_mark(node: yaml.Node) -> int:
    """Where a value's own text ends: a block collection's end mark lies past the comments
    and blank lines after it, which belong to the next key."""
    if isinstance(node, yaml.ScalarNode) or node.flow_style or not node.value:
        return node.end_mark.index
    last = node.value[-1]
    return _last_mark(last[1] if isinstance(last, tuple) else last)


def write_landmarks(plan: FloorPlan, landmarks: Landmarks) -> FloorPlan:
    """Write the markers into the plan's file and return the plan read back from it. The
    new text goes to a temporary file beside it, which must pass every check before it
    replaces the file: whatever happens, the file is either as it was or complete."""
    path = plan.path
    if path.is_symlink():
        # Renaming over a link would replace the link, not the plan it points to.
        raise ValueError(f"{path} is a symbolic link: give the file it points to")
    text = read_bounded(path).decode("utf-8")  # its line endings kept
    block = landmarks_block(plan, landmarks)
    if "\r\n" in text:
        block = block.replace("\n", "\r\n")  # a file written on Windows stays as it was
    new_text = with_landmarks(text, block)
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(handle, "w", encoding="utf-8", newline="") as out:
            out.write(new_text)
            out.flush()
            os.fsync(out.fileno())
        os.chmod(temporary, path.stat().st_mode & 0o7777)
        try:
            written = load_floorplan(temporary)
        except FloorPlanError as error:
            problems = [Problem(path, p.line, p.message) for p in error.problems]
            raise FloorPlanError(problems) from None
        if written.landmarks != landmarks or _rest(written) != _rest(plan):
            raise FloorPlanError([Problem(path, None, "the plan did not read back as written")])
        os.replace(temporary, path)
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)
    return load_floorplan(path)


def _rest(plan: FloorPlan) -> tuple:
    """All of a plan but its markers and where it was read from."""
    grid = plan.grid and replace(plan.grid, image=plan.grid.image.resolve())
    return plan.name, plan.rooms, plan.doors, grid, plan.start
