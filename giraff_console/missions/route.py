"""Taught routes: the operator drives once, the robot replays it later (§2.6.1, §2.6.3).

§2.6.1's "recorded route" is the simplest planner: a person steers the robot where it
needs to go, and the robot replays the recorded actions. The teacher keeps the motion
settings teleop sent while teaching, with their times, and the board's settings when
teaching began, so that a replay starts from the same board. Along the way it samples
the dead-reckoned path, and it keeps the places the operator names (§2.6.3: "told the
name of the room the robot is in"), which later planning can use as waypoints with
known coordinates (§2.6.1's graph of routes between waypoints).

Route files are YAML written for people to read; routes/README.md describes them.
"""

from __future__ import annotations

import math
import os
import tempfile
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

import yaml

from giraff_console.link.exchange import Exchange
from giraff_console.missions.yaml_file import YamlFile, name_problem, shown
from giraff_console.private_files import private_folder
from giraff_console.protocol.codec import Command, format_number, parse_command, parse_number
from giraff_console.protocol.errors import CommandError, GiraffError
from giraff_console.robot.odometry import Pose
from giraff_console.robot.twm import separate_moves

FORMAT = 1
# The settings a move is made of, in the order a replay sends them; `set p` starts it.
MOTION_SETTINGS = ("r", "mode", "a", "v", "vg", "vgr", "cdp")
TAUGHT_SETTINGS = frozenset((*MOTION_SETTINGS, "p"))
# The path is kept at least every 0.25 m or 10 degrees; sampling at half that leaves room
# for the odometry's step between two polls.
SAMPLE_DISTANCE_M = 0.1
SAMPLE_TURN_RAD = math.radians(5)
_HEADER = "# A route taught to giraff-console; routes/README.md describes the format.\n"


class RouteError(GiraffError):
    """A route that cannot be taught, saved or read; the message says why."""


def check_name(name: object, what: str) -> str:
    """A route or place name: it becomes a file name and a word typed in commands."""
    problem = name_problem(name, what)
    if problem:
        raise RouteError(problem)
    assert isinstance(name, str)
    return name


@dataclass(frozen=True)
class TimedCommand:
    """A command teleop sent, `offset` seconds after teaching began."""

    offset: float
    command: Command


@dataclass(frozen=True)
class PathSample:
    """Where odometry put the robot `offset` seconds in: metres, radians (Pose)."""

    offset: float
    x: float
    y: float
    heading: float


@dataclass(frozen=True)
class Mark:
    """A place the operator named while teaching, and the pose it was named at."""

    name: str
    offset: float
    x: float
    y: float
    heading: float


@dataclass(frozen=True)
class Route:
    """A taught route: the board's settings at the start, then what teleop sent."""

    name: str
    taught: str
    session: str | None
    settings: dict[str, str]
    commands: list[TimedCommand]
    path: list[PathSample]
    marks: list[Mark]
    duration: float


class RouteTeacher:
    """Records a route while the operator drives, between `teach NAME` and `done`."""

    def __init__(
        self,
        name: str,
        started_at: float,
        start_pose: Pose,
        board_settings: dict[str, str],
        session: str | None,
        *,
        taught: str | None = None,
    ) -> None:
        """`board_settings` as Teleop.board_settings gives them; `taught` defaults to now."""
        self.name = check_name(name, "route")
        self.started_at = started_at
        self.session = session
        self.taught = taught or datetime.now().astimezone().isoformat(timespec="seconds")
        self._settings = {k: v for k, v in board_settings.items() if k in MOTION_SETTINGS}
        self._commands: list[TimedCommand] = []
        self._path: list[PathSample] = []
        self._marks: dict[str, Mark] = {}
        self.observe_pose(started_at, start_pose)

    def observe_exchange(self, exchange: Exchange) -> None:
        """Keep the motion settings the board took; polls, gets and failures are not driving."""
        if exchange.kind != "set" or exchange.automatic or exchange.error is not None:
            return
        offset = exchange.sent_at - self.started_at
        try:
            command = parse_command(exchange.command)
        except CommandError:
            return
        # A Giraff-X's one-command curve is kept as the sets it stands for, so that the
        # route replays on any board (the loop folds them again on a Giraff-X).
        for part in separate_moves(command):
            if offset >= 0 and part.name in TAUGHT_SETTINGS:
                self._commands.append(TimedCommand(offset, part))

    def observe_pose(self, now: float, pose: Pose) -> None:
        """Sample the path once the robot has moved or turned enough since the last sample."""
        sample = PathSample(max(now - self.started_at, 0.0), pose.x, pose.y, pose.heading)
        if not self._path:
            self._path.append(sample)
            return
        last = self._path[-1]
        moved = math.hypot(sample.x - last.x, sample.y - last.y)
        turned = abs(math.remainder(sample.heading - last.heading, math.tau))
        if moved >= SAMPLE_DISTANCE_M or turned >= SAMPLE_TURN_RAD:
            self._path.append(sample)

    def mark(self, place: str, now: float, pose: Pose) -> Mark:
        """Name the robot's pose `place`; naming a place again moves it here."""
        check_name(place, "place")
        mark = Mark(place, max(now - self.started_at, 0.0), pose.x, pose.y, pose.heading)
        self._marks.pop(place, None)
        self._marks[place] = mark
        return mark

    def finish(self, now: float, pose: Pose) -> Route:
        """The route as taught, with the pose at `done` as its last path sample."""
        end = PathSample(max(now - self.started_at, 0.0), pose.x, pose.y, pose.heading)
        path = self._path if self._path[-1] == end else [*self._path, end]
        commands = sorted(self._commands, key=lambda timed: timed.offset)
        duration = max(end.offset, commands[-1].offset if commands else 0.0)
        return Route(
            self.name, self.taught, self.session, dict(self._settings), commands,
            list(path), list(self._marks.values()), duration,
        )  # fmt: skip


def save_route(route: Route, directory: Path) -> Path:
    """Write `<directory>/<name>.yaml` whole or not at all; returns its path."""
    check_name(route.name, "route")
    document = {
        "format": FORMAT,
        "taught": route.taught,
        "session": route.session,
        "duration": round(route.duration, 3),
        "settings": dict(route.settings),
        "commands": [[round(c.offset, 3), c.command.text] for c in route.commands],
        "marks": {m.name: _pose_row(m) for m in route.marks},
        "path": [_pose_row(sample) for sample in route.path],
    }
    text = _HEADER + yaml.safe_dump(document, default_flow_style=None, sort_keys=False, width=100)
    path = Path(directory) / f"{route.name}.yaml"
    temp: str | None = None
    try:
        private_folder(path.parent)
        # mkstemp makes the file 0600: the route is the operator's alone, as it is written.
        fd, temp = tempfile.mkstemp(dir=path.parent, prefix=f".{route.name}.", suffix=".tmp")
        with os.fdopen(fd, "w", encoding="utf-8") as file:
            file.write(text)
        os.replace(temp, path)
    except OSError as error:
        if temp is not None:
            Path(temp).unlink(missing_ok=True)
        raise RouteError(f"cannot save route {route.name} to {path}: {error.strerror}") from None
    return path


def load_route(path: Path) -> Route:
    """Read a route file; RouteError names the file and what is wrong with it."""
    file = YamlFile(Path(path), RouteError)
    doc = file.mapping(
        required=("format", "taught", "duration", "settings", "commands"),
        optional=("session", "marks", "path"),
    )
    name = file.name(file.path.name.removesuffix(".yaml"), "route")
    if doc["format"] != FORMAT or isinstance(doc["format"], bool):
        file.fail(
            f"format {shown(doc['format'])} is not one this console reads (format: {FORMAT})",
            "format",
        )
    session = doc.get("session")
    duration = file.number(doc["duration"], "duration", minimum=0)
    settings = file.table(doc["settings"], "settings", MOTION_SETTINGS)
    commands = [
        TimedCommand(offset, _motion_command(file, text, f"commands[{i}]"))
        for i, (offset, text) in enumerate(file.timed_rows(doc["commands"], "commands", 2))
    ]
    if commands and commands[-1].offset > duration:
        file.fail(
            f"duration {duration} s ends before the last command, at {commands[-1].offset} s",
            "duration",
        )
    rows = file.timed_rows(doc.get("path") or [], "path", 4)
    marks = file.table(doc.get("marks") or {}, "marks", None)
    file.within_limit(marks, "marks", "places")
    return Route(
        name=name,
        taught=file.text(doc["taught"], "taught"),
        session=None if session is None else file.text(session, "session"),
        settings={
            key: _wire_value(file, value, f"settings.{key}") for key, value in settings.items()
        },
        commands=commands,
        path=[PathSample(*_pose(file, row, f"path[{i}]")) for i, row in enumerate(rows)],
        marks=[
            Mark(file.name(place, "place", f"marks.{place}"), *_pose(file, row, f"marks.{place}"))
            for place, row in marks.items()
        ],
        duration=duration,
    )


def list_routes(directory: Path) -> list[str]:
    """The names of the routes in `directory`, sorted; patrol files are not routes."""
    return sorted(
        path.name.removesuffix(".yaml")
        for path in Path(directory).glob("*.yaml")
        if not path.name.endswith(".patrol.yaml")
    )


def _pose_row(at: PathSample | Mark) -> list[float]:
    """`[offset s, x m, y m, heading degrees]`, to the millisecond, millimetre, 0.01 degree."""
    heading = round(math.degrees(at.heading), 2)
    return [round(at.offset, 3), round(at.x, 3), round(at.y, 3), heading]


def _pose(file: YamlFile, row: object, where: str) -> tuple[float, float, float, float]:
    if not isinstance(row, list) or len(row) != 4:
        file.fail(f"{where} should be [offset, x, y, heading], not {shown(row)}", where)
    offset, x, y, heading = (file.number(value, f"{where}[{i}]") for i, value in enumerate(row))
    return offset, x, y, math.radians(heading)


def _wire_value(file: YamlFile, value: object, where: str) -> str:
    """A setting's value as the wire carries it; a person may write a bare number."""
    try:
        if isinstance(value, str):
            return format_number(parse_number(value))
        return format_number(file.number(value, where))
    except CommandError as error:
        file.fail(f"{where}: {error}", where)


def _motion_command(file: YamlFile, text: object, where: str) -> Command:
    try:
        command = parse_command(file.text(text, where))
    except CommandError as error:
        file.fail(f"{where}: {shown(text)}: {error}", where)
    if command.kind != "set" or command.name not in TAUGHT_SETTINGS:
        file.fail(
            f"{where}: {shown(text)} is not a motion setting (set p, v, a, r, mode, vg, vgr, cdp)",
            where,
        )
    return command
