"""`giraff-console floorplan`: check a floor plan, draw it, import one from a map, place
its markers, find its rooms.
"""

from __future__ import annotations

import argparse
import math
import shutil
import sys
from pathlib import Path
from typing import TYPE_CHECKING

# Only what the parser needs is imported here: every command, `--version` and `--help`
# included, pays for these before it reads its arguments. What a command needs to run
# (numpy, OpenCV, scipy, the planner, the robot, Textual) is imported by the command,
# when it runs (issue 26, item 6; tests/test_cli.py keeps it so).
from giraff_console.cli.exit_codes import EXIT_USAGE
from giraff_console.planning.defaults import DEFAULT_EVERY_M, MIN_ROOM_M2, ROBOT_RADIUS_M

if TYPE_CHECKING:
    pass


def add_floorplan_parser(commands: argparse._SubParsersAction, example: Path) -> None:
    floorplan = commands.add_parser(
        "floorplan",
        help="check a floor plan file",
        description="Check FILE against the floor plan format (floorplans/README.md) and "
        "print every problem as FILE:LINE: message. Exits 0 if there is none, 2 otherwise.",
    )
    floorplan_commands = floorplan.add_subparsers(dest="floorplan_command", metavar="ACTION",
                                                  required=True)  # fmt: skip
    check = floorplan_commands.add_parser("check", help="report every problem in a floor plan")
    check.add_argument("file", type=Path, metavar="FILE")
    show = floorplan_commands.add_parser(
        "show", help="draw a floor plan in the terminal",
        description="Draw FILE's grid (or, without one, its outlines) with each room's id.",
    )  # fmt: skip
    show.add_argument("file", type=Path, metavar="FILE")
    show.add_argument(
        "--width", type=int, metavar="COLUMNS",
        help="columns to fit the drawing in (default: the terminal's width)",
    )  # fmt: skip
    imports = floorplan_commands.add_parser(
        "import", help="make a floor plan from an Open-RMF building map",
        description="Write OUT, a floor plan made from one level of SOURCE, an Open-RMF "
        "*.building.yaml as traffic-editor saves it: its named vertices become rooms, the "
        "spaces its walls and doors bound (or, without walls, its lanes) say which rooms "
        "its doors join, and passages join rooms that share a space. With walls, the grid "
        "is drawn from them and written next to OUT as a PGM (floorplans/README.md, "
        "\"Importing\"). Positions are read in metres from traffic-editor's "
        "coordinate systems: reference_image (pixels, scaled by the level's measurements), "
        "cartesian_meters, or wgs84 (longitude, latitude), which is projected onto the "
        "plane tangent to the WGS 84 ellipsoid at the building's middle (the median of its "
        "vertices), x east and y north: true to the ground within a millimetre over 5 km, "
        "with no map grid's scale or north to undo. What the import decides for the map is "
        "told in notes, at their "
        "lines. The result must pass `floorplan check`, or nothing is written. Exits 0 "
        "when written, 2 for a bad SOURCE or MAP.",
    )  # fmt: skip
    imports.add_argument("source", type=Path, metavar="SOURCE.building.yaml")
    imports.add_argument("out", type=Path, metavar="OUT.yaml")
    imports.add_argument(
        "--level", metavar="NAME",
        help="the level to import (default: the only one; a map of several must say which)",
    )  # fmt: skip
    imports.add_argument(
        "--graph", type=int, metavar="N",
        help="only the lanes of graph N (a fleet's graph_idx), and the named vertices on "
        "them or on no lane (default: every graph's)",
    )  # fmt: skip
    imports.add_argument(
        "--grid", type=Path, metavar="MAP.yaml",
        help="a ROS map_server map to use as the grid, instead of the one drawn from the "
        "walls; its image is copied next to OUT",
    )  # fmt: skip
    imports.add_argument(
        "--name", metavar="TEXT", help="the floor plan's name (default: building and level)",
    )  # fmt: skip
    imports.add_argument("--force", action="store_true", help="overwrite OUT and its image")
    landmarks = floorplan_commands.add_parser(
        "landmarks", help="place markers on a floor plan's walls, or print them",
        description="Place fiducial markers (AprilTag 36h11) on FILE's walls, for the robot "
        "to find itself by: beside every doorway on both sides, along walls at least M "
        "metres long, and on the wall nearest any room's stop that would read too few to "
        "confirm an arrival there; and write them into FILE (floorplans/README.md, "
        "\"Landmarks\"). The walls are the rooms' outlines, or in a plan without outlines "
        "(an import, rooms found in a scan) the walls in its grid, where the robot sees "
        "them. Markers already there stay, at the plan's size. A plan without markers gets "
        "them 0.16 m across, or larger where a room's stop is far from every wall (up to "
        "0.26 m), unless --size says. With --print, write one page per marker to DIR "
        "instead, to print at actual size and put up. Exits 2 for a bad floor plan.",
    )  # fmt: skip
    landmarks.add_argument("file", type=Path, metavar="FILE")
    landmarks_action = landmarks.add_mutually_exclusive_group()
    landmarks_action.add_argument(
        "--every", type=float, default=DEFAULT_EVERY_M, metavar="M",
        help="metres between markers along a long wall (default: %(default)s)",
    )  # fmt: skip
    landmarks.add_argument(
        "--size", type=float, metavar="M",
        help="the side of the markers' black squares in metres, for a plan without markers "
        "(default: the least that every room's stop reads, 0.16 to 0.26)",
    )  # fmt: skip
    landmarks_action.add_argument(
        "--print", type=Path, metavar="DIR", dest="print_to",
        help="write a PNG page for each marker in FILE, and all of them in DIR/markers.pdf",
    )  # fmt: skip
    rooms = floorplan_commands.add_parser(
        "rooms", help="find the rooms and doors in a scanned map",
        description="Write OUT, a floor plan of the rooms and doors found in MAP, a ROS "
        "map_server map such as SLAM leaves (floorplans/README.md, \"Rooms from a scan\"). "
        "Rooms are where the free space is wide, doors where it narrows between them to "
        "1.4 m or less (a wider opening is a way within a room, and furniture makes no "
        "room); rooms are named by --mark, the rest room-1, room-2, ... from the top "
        "left, each with its point where "
        "it is furthest from walls, and the plan has no outlines: the grid is its walls, "
        "and its grid is written next to OUT: the map's image copied, or, when the map "
        "had to be cropped to its floor or cleared of specks of noise, the grid so "
        "redrawn (MAP itself is never changed). Rooms the route planner cannot reach "
        "from the rest are left out, with a note. A picture of what was found (each room "
        "tinted and named, doors in red) goes next to OUT too. The plan must pass "
        "`floorplan check`, or nothing is written. Exits 0 when written, 2 for a map that "
        "cannot be read or has no rooms in it, for several rooms no two of which the "
        "robot can be planned between, and for an output that cannot be written.",
    )  # fmt: skip
    rooms.add_argument("map", type=Path, metavar="MAP.yaml")
    rooms.add_argument("out", type=Path, metavar="OUT.yaml")
    rooms.add_argument(
        "--picture", type=Path, metavar="PNG",
        help="where to draw the rooms found (default: beside OUT, plan.yaml's is "
        "plan-rooms.png)",
    )  # fmt: skip
    rooms.add_argument(
        "--name", metavar="TEXT", help="the floor plan's name (default: from MAP's name)",
    )  # fmt: skip
    rooms.add_argument(
        "--robot-radius", type=float, default=ROBOT_RADIUS_M, metavar="M",
        help="free space narrower than twice this and the route planner's 0.05 m "
        "clearance is no room, and no door (default: %(default)s)",
    )  # fmt: skip
    rooms.add_argument(
        "--min-area", type=float, default=MIN_ROOM_M2, metavar="M2",
        help="square metres of floor a room needs; smaller pieces join their "
        "neighbours (default: %(default)s)",
    )  # fmt: skip
    rooms.add_argument(
        "--mark", action="append", default=[], metavar="NAME=X,Y",
        help="name the room holding map point X,Y (metres, the map's frame) NAME, as "
        "`mark NAME` does while mapping; repeat for each room marked. Rooms not marked "
        "are room-N. A mark on no room, two in one room, a name twice or a name that is "
        "not a room id is refused, and nothing is written",
    )  # fmt: skip
    rooms.add_argument("--force", action="store_true",
                       help="overwrite OUT, its image and the picture")  # fmt: skip


def run_floorplan(args: argparse.Namespace) -> int:
    """The floor plan command `args` names: check (the default), show, import,
    landmarks or rooms."""
    command = {"show": run_floorplan_show, "import": run_floorplan_import,
               "landmarks": run_floorplan_landmarks, "rooms": run_floorplan_rooms}.get(
        args.floorplan_command, run_floorplan_check)  # fmt: skip
    return command(args)


def run_floorplan_check(args: argparse.Namespace) -> int:
    """Every problem in a floor plan, one per line."""
    from giraff_console.planning.floorplan import check_floorplan

    problems = check_floorplan(args.file)
    for problem in problems:
        print(problem)
    if problems:
        return EXIT_USAGE
    print(f"{args.file}: no problems")
    return 0


def run_floorplan_show(args: argparse.Namespace) -> int:
    """The plan drawn in the terminal."""
    from giraff_console.planning.floorplan import FloorPlanError, load_floorplan
    from giraff_console.planning.plan_drawing import draw_plan

    width = args.width or shutil.get_terminal_size().columns
    try:
        lines = draw_plan(load_floorplan(args.file), width)
    except (FloorPlanError, OSError, ValueError) as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    print("\n".join(lines))
    return 0


def run_floorplan_import(args: argparse.Namespace) -> int:
    """A floor plan made from an Open-RMF building map, with a grid drawn from its walls or
    a ROS map's."""
    # Imported here: of all the commands, only this one reads RMF and ROS maps.
    from giraff_console.planning.floorplan import FloorPlanError
    from giraff_console.planning.output_files import OutputError, check_outputs
    from giraff_console.planning.plan_writing import write_floorplan
    from giraff_console.planning.rmf_import import read_building
    from giraff_console.planning.rmf_source import BuildingError
    from giraff_console.planning.ros_map import read_ros_map

    imported = None

    def tell_notes(notes: list[str]) -> None:
        # Each is `file:line: note: ...`, in the order of the lines.
        for note in notes:
            print(f"giraff-console: {note}", file=sys.stderr)

    try:
        imported = read_building(args.source, args.level, args.name, args.graph)
        grid = read_ros_map(args.grid) if args.grid is not None else None
        # Never over SOURCE or MAP, --force or not: it is for an old result.
        inputs = [("SOURCE", args.source)]
        outputs = [("OUT", args.out)]
        if grid is not None:
            inputs += [("MAP", args.grid), ("MAP's image", grid.image)]
            image = args.out.with_suffix(grid.image.suffix)
            if not (image.exists() and image.samefile(grid.image)):  # else used as it is
                outputs.append(("OUT's grid image", image))
        elif imported.drawn is not None:
            outputs.append(("OUT's grid image", args.out.with_suffix(".pgm")))
        check_outputs(outputs, inputs, args.force)
        written = write_floorplan(imported, args.out, grid, force=args.force)
    except OutputError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    except FloorPlanError as error:
        tell_notes(error.notes if isinstance(error, BuildingError) else
                   imported.notes if imported is not None else [])  # fmt: skip
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    except FileExistsError as error:
        print(f"giraff-console: {error.filename} exists: --force overwrites it", file=sys.stderr)
        return EXIT_USAGE
    except OSError as error:
        print(f"giraff-console: cannot write {args.out}: {error}", file=sys.stderr)
        return EXIT_USAGE
    tell_notes(imported.notes)
    plan = imported.plan
    rooms, doors = plan["rooms"], [door["id"] for door in plan["doors"]]
    start = f", starting in {plan['start']}" if "start" in plan else ""
    print(f"wrote {written[0]}: {len(rooms)} rooms ({', '.join(rooms)}), "
          f"{len(doors)} doors ({', '.join(doors) or 'none'}){start}")  # fmt: skip
    for image in written[1:]:
        made = f"the grid image of {args.grid}" if args.grid is not None else (
            "the grid, drawn from the level's walls and doors")  # fmt: skip
        print(f"wrote {image}: {made}")
    return 0


def run_floorplan_landmarks(args: argparse.Namespace) -> int:
    """Markers placed on a floor plan and written into it, or its markers' pages."""
    from giraff_console.planning.floorplan import FloorPlanError, load_floorplan
    from giraff_console.planning.landmark_placement import place_markers, write_landmarks
    from giraff_console.planning.marker_pages import write_pages

    try:
        plan = load_floorplan(args.file)
        if args.print_to is not None:
            written = write_pages(plan, args.print_to)
            pages = f"{len(written) - 1} page{'s' if len(written) != 2 else ''}"
            print(f"wrote {pages} to {args.print_to}, and all of them in "
                  f"{written[-1]}: print them at actual size (100 %)")  # fmt: skip
            return 0
        placement = place_markers(plan, args.every, args.size)
        if placement.added:
            write_landmarks(plan, placement.landmarks)
    except (FloorPlanError, ValueError, OSError) as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    for note in placement.notes:
        print(f"giraff-console: {args.file}: {note}", file=sys.stderr)
    total = len(placement.landmarks.markers)
    print(f"{args.file}: placed {placement.added} markers ({placement.beside_doors} beside "
          f"doorways, {placement.along_walls} along walls, {placement.for_stops} for rooms' "
          f"stops); it has {total} in all, {placement.landmarks.size:g} m across")  # fmt: skip
    return 0


def run_floorplan_rooms(args: argparse.Namespace) -> int:
    """A floor plan of the rooms found in a scanned map, and a picture of them."""
    # Imported here: of all the commands, only this one segments maps.
    from giraff_console.planning.floorplan import FloorPlanError
    from giraff_console.planning.output_files import OutputError, check_outputs
    from giraff_console.planning.plan_writing import write_floorplan
    from giraff_console.planning.room_picture import draw_rooms, encode_png
    from giraff_console.planning.room_segmentation import (
        MarkError,
        SegmentationError,
        scan_plan,
        segment_rooms,
    )
    from giraff_console.planning.scan_grid import read_scan

    for option, value in (("--robot-radius", args.robot_radius), ("--min-area", args.min_area)):
        if not (value > 0 and math.isfinite(value)):
            print(f"giraff-console: {option} must be a positive number", file=sys.stderr)
            return EXIT_USAGE
    marks = _marks(args.mark)
    if marks is None:
        return EXIT_USAGE
    picture = args.picture or args.out.with_name(f"{args.out.stem}-rooms.png")
    try:
        scan = read_scan(args.map)
        found = segment_rooms(scan.grid, args.robot_radius, args.min_area, scan.cropped, marks)
    except FloorPlanError as error:
        for problem in error.problems:
            print(f"giraff-console: {problem}", file=sys.stderr)
        return EXIT_USAGE
    except MarkError as error:
        for issue in error.issues:
            print(f"giraff-console: {args.map}: {issue.detail}", file=sys.stderr)
        return EXIT_USAGE
    except SegmentationError as error:
        print(f"giraff-console: {args.map}: {error}", file=sys.stderr)
        return EXIT_USAGE
    # A grid cropped or cleaned is written as a PGM; the map's own is copied as it is.
    image = args.out.with_suffix(".pgm" if found.redrawn else scan.spec.image.suffix)
    try:
        outputs = [("OUT", args.out), ("OUT's grid image", image), ("--picture", picture)]
        check_outputs(outputs, [("MAP", args.map), ("MAP's image", scan.spec.image)], args.force)
        # Drawn before anything is written, so that a failure leaves nothing behind.
        png = encode_png(draw_rooms(found))
        name = args.name or f"Rooms found in {args.map.name}"
        made = scan_plan(found, args.map, name)
        written = write_floorplan(made, args.out, None if found.redrawn else scan.spec,
                                  args.force)  # fmt: skip
        picture.write_bytes(png)
    except OutputError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    except FloorPlanError as error:
        for problem in error.problems:
            print(f"giraff-console: {problem}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as error:
        print(f"giraff-console: cannot write {error.filename or args.out}: "
              f"{error.strerror or error}", file=sys.stderr)  # fmt: skip
        return EXIT_USAGE
    for note in (*scan.notes, *found.notes):
        print(f"giraff-console: {args.map}: {note}", file=sys.stderr)
    rooms = [room.id for room in found.rooms]
    named = f"{rooms[0]} to {rooms[-1]}" if len(rooms) > 1 else rooms[0]
    doors = ", ".join(door.id for door in found.doors) or "none"
    rooms_s, doors_s = "s" * (len(rooms) != 1), "s" * (len(found.doors) != 1)
    print(f"wrote {written[0]}: {len(rooms)} room{rooms_s} ({named}), {len(found.doors)} "
          f"door{doors_s} ({doors}), starting in {found.start}")  # fmt: skip
    made_as = "redrawn as noted above" if found.redrawn else "its image copied"
    for grid_image in written[1:]:
        print(f"wrote {grid_image}: the grid of {args.map}, {made_as}")
    print(f"wrote {picture}: the rooms found, to check and name")
    return 0


def _marks(given: list[str]) -> list[tuple[str, tuple[float, float]]] | None:
    """The --mark options as names and points; None, said in a line each, if any is not
    NAME=X,Y with X and Y finite numbers."""
    marks = []
    for text in given:
        name, _, where = text.partition("=")
        parts = where.split(",")
        try:
            x, y = (float(part) for part in parts)
        except ValueError:
            x = y = math.nan
        if not (name and math.isfinite(x) and math.isfinite(y)):
            said = (f"--mark {text}: give NAME=X,Y, the room's name and a point in it in "
                    "metres, as the map's origin counts them")  # fmt: skip
            print(f"giraff-console: {said}", file=sys.stderr)
            return None
        marks.append((name, (x, y)))
    return marks
