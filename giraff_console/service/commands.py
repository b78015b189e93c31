"""What a front end may ask of the robot: commands as frozen dataclasses (issue 15).

A front end hands the robot data, never a function to run (design.md), so that the same
request works in-process and from another process, across the daemon's socket. The
table `TYPED` says, once, how each command is typed on a command line, what it does
for the help screen, and how its text becomes the command; the console's command line,
its help screen and the CLI's `giraff-console do …` all read it.

`moves` says whether a command can move the robot: only the console holding the
controls may send one. A stop of any kind is open to everyone.

Each field says what it may hold (`Annotated[str, ROOM]`): the bounds below, within what
the robot means. A request that comes across the daemon's socket is held to them as it
is decoded (service/wire.py), before anything acts on it, and refused naming the field
and what was expected (issue 30, item 4): nothing a client sends reaches the service or
the control loop unchecked. Requests made in this process come from the typed words
below or from the fleet, which check what they take.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, ClassVar

from giraff_console.protocol import CommandError, parse_number
from giraff_console.robot.deadman import Intent
from giraff_console.service.wire import Count, Number, Text


class Usage(ValueError):
    """Text that does not make a command; says how to type it."""


# -- what a request may hold ----------------------------------------------------------

# Rooms, doors and routes are named as the floor plan's ids are (planning/floorplan.py
# `_ID`, missions/yaml_file.py `_NAME`): words typed in commands and parts of file names,
# so no spaces, no slashes, nothing a shell or a path would read otherwise.
_ID = re.compile(r"[A-Za-z0-9_-]{1,64}")
ROOM = Text("a room's id (1 to 64 letters, digits, '-' or '_')", 64, _ID)
DOOR = Text("a door's id (1 to 64 letters, digits, '-' or '_')", 64, _ID)
PLACE = Text("a place's name (1 to 64 letters, digits, '-' or '_')", 64, _ID)
ROUTE = Text("a route's name (1 to 64 letters, digits, '-' or '_')", 64, _ID)
# A patrol is named, or given by its file's path (`giraff-console patrol FILE`).
PATROL = Text(
    "a patrol's name (1 to 64 letters, digits, '-' or '_') or the path of its .patrol.yaml",
    4096,
    re.compile(r"[A-Za-z0-9_-]{1,64}|[^\x00-\x1f\x7f]{0,4085}\.patrol\.yaml"),
)
# A controller command goes to the board as a line: printable ASCII, nothing to end it
# early and start another. The longest the board takes (`set twm` and its values, each
# at most 40 characters: protocol/codec.py) is far shorter.
COMMAND = Text("a controller command (at most 400 printable ASCII characters)", 400,
               re.compile(r"[\x20-\x7e]*"))  # fmt: skip
CONSOLE = Text("a console's name (1 to 200 printable characters)", 200,
               re.compile(r"[^\x00-\x1f\x7f]{1,200}"))  # fmt: skip
# PATH_MAX on Linux; a path sent from another process was resolved there.
PATH = Text("a path of at most 4096 characters", 4096)
# No Giraff drives at 2 m/s; teleop's own cap (settings: max_speed) is lower still.
SPEED = Number("a speed from 0 to 2 m/s", 0.0, 2.0)
SPEED_STEPS = Number("a number of 0.05 m/s steps from -40 to 40", -40, 40)
HEIGHT = Number("a stalk height from 0 to 1000", 0, 1000)
HEIGHT_STEPS = Number("a number of stalk steps from -1000 to 1000", -1000, 1000)
# A building the size of an airport (300 x 150 m) fits many times over.
COORDINATE = Number("a map coordinate from -10000 to 10000 m", -10_000.0, 10_000.0)
HEADING = Number("a heading from -360 to 360 degrees", -360.0, 360.0)
# A session is seconds to hours long; a week bounds any of them.
WEEK_S = 7 * 24 * 3600.0
OFFSET = Number("a time from 0 to 604800 s (a week) into the session", 0.0, WEEK_S)
SHIFT = Number("a shift from -604800 to 604800 s", -WEEK_S, WEEK_S)
# What the playback runs at (recording/playback.py SPEEDS), and a factor that gets there.
PLAY_RATE = Number("a rate from 0.25 to 16 times real speed", 0.25, 16.0)
RATE_FACTOR = Number("a factor from 1/64 to 64", 1 / 64, 64.0)


@dataclass(frozen=True)
class Request:
    """A command to the robot service."""

    # Whether it may move the robot (the controls' holder alone may send it).
    moves: ClassVar[bool] = False
    # Whether it is answered at once: a key must not wait behind a route being planned.
    quick: ClassVar[bool] = False


# -- driving by hand ------------------------------------------------------------------


@dataclass(frozen=True)
class Press(Request):
    """An arrow key, pressed or repeated: teleop's deadman drives while they come."""

    intent: Intent
    moves: ClassVar[bool] = True
    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Halt(Request):
    """Stop now: let go of the keys, end the mission, stop the wheels. Anyone may."""

    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Speed(Request):
    """Teleop's driving speed: `to` m/s, or `step` 0.05 m/s steps from where it is."""

    to: Annotated[float, SPEED] | None = None
    step: Annotated[int, SPEED_STEPS] = 0
    moves: ClassVar[bool] = True
    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Send(Request):
    """A controller command as typed (`set v 0.3`, `get bulk_data`), checked against the
    limits on the loop's thread before it goes."""

    text: Annotated[str, COMMAND]
    moves: ClassVar[bool] = True
    quick: ClassVar[bool] = True


# The most controller commands asked for at once (SendCommands): the loop sends them
# all in one go, between two of its ticks, so that nothing changes the board's settings
# between their check and the last of them; a longer batch would hold the loop longer.
MAX_COMMANDS = 32


@dataclass(frozen=True)
class SendCommands(Request):
    """Controller commands as typed, for `giraff-console send`: each checked against the
    limits and the board's settings as the ones before it leave them, all on the loop's
    thread before any is sent (if one is refused, none is sent), then sent in order;
    answered once the board has answered them all, with its answers (Reply.sent).

    Only the holder of the controls may send a `set` or a bare command; anyone may read
    (robot_service._moves)."""

    texts: Annotated[
        tuple[Annotated[str, COMMAND], ...], Count(f"1 to {MAX_COMMANDS} commands", MAX_COMMANDS, 1)
    ]
    moves: ClassVar[bool] = True


@dataclass(frozen=True)
class Stalk(Request):
    """The head's height stalk: `to` 0..1000, or `step` steps from its last height."""

    to: Annotated[int, HEIGHT] | None = None
    step: Annotated[int, HEIGHT_STEPS] = 0
    moves: ClassVar[bool] = True
    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Poll(Request):
    """The automatic odometry poll on or off (None: the other way)."""

    on: bool | None = None
    quick: ClassVar[bool] = True


# -- missions -------------------------------------------------------------------------


@dataclass(frozen=True)
class Go(Request):
    """Plan a route to a room of the floor plan (or the dock) and drive it."""

    room: Annotated[str, ROOM]
    moves: ClassVar[bool] = True


@dataclass(frozen=True)
class RunPatrol(Request):
    """Run the patrol `name` from the routes folder."""

    name: Annotated[str, PATROL]
    moves: ClassVar[bool] = True


@dataclass(frozen=True)
class Follow(Request):
    """Drive a taught route's path closed-loop, from its start."""

    name: Annotated[str, ROUTE]
    moves: ClassVar[bool] = True


@dataclass(frozen=True)
class Replay(Request):
    """Drive a taught route again, open-loop, with its original timing."""

    name: Annotated[str, ROUTE]
    moves: ClassVar[bool] = True
    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Undock(Request):
    """Back out of the dock and turn round, in steps the console streams."""

    moves: ClassVar[bool] = True
    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Pause(Request):
    """Hold the mission (or the playback) where it is."""

    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Resume(Request):
    """Go on with the mission (or the playback)."""

    moves: ClassVar[bool] = True
    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class StopMission(Request):
    """End the mission; the robot stops where it is. An operator's stop (`operator`)
    also holds what else may move the robot (the program on the virtual port) until
    `release`; the fleet's cancel of its own order holds nothing."""

    operator: bool = True
    quick: ClassVar[bool] = True


# -- the building ---------------------------------------------------------------------


@dataclass(frozen=True)
class Door(Request):
    """Shut or open a door of the plan (and of the simulated building); routes go round."""

    door: Annotated[str, DOOR]
    open: bool
    # It plans the mission under way again.
    moves: ClassVar[bool] = True


@dataclass(frozen=True)
class Block(Request):
    """Simulator: put a box in the way at x, y metres, or take it away."""

    x: Annotated[float, COORDINATE]
    y: Annotated[float, COORDINATE]
    on: bool = True
    quick: ClassVar[bool] = True


# -- sessions and routes --------------------------------------------------------------


@dataclass(frozen=True)
class Record(Request):
    """Start (or, `on` False, stop) recording a session."""

    on: bool = True
    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Play(Request):
    """Play a session back (the newest without `session`), or stop the playback."""

    session: Annotated[Path, PATH] | None = None
    stop: bool = False
    # A playback ends the mission and takes the keys: the robot's, not a watcher's.
    moves: ClassVar[bool] = True
    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Seek(Request):
    """Move the playback to `to` seconds in, or `by` seconds on (negative: back)."""

    to: Annotated[float, OFFSET] | None = None
    by: Annotated[float, SHIFT] = 0.0
    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Rate(Request):
    """Play back at `to` times real speed, or `times` the present speed."""

    to: Annotated[float, PLAY_RATE] | None = None
    times: Annotated[float, RATE_FACTOR] = 1.0
    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Step(Request):
    """Pause the playback and step to its next line."""

    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Teach(Request):
    """Start teaching route `name`: the operator drives, `mark` names places."""

    name: Annotated[str, ROUTE]
    moves: ClassVar[bool] = True
    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Mark(Request):
    """Name the place where the robot stands: on the route being taught, else the room
    it stands in is renamed `place` (§2.6.3), as `Name` does."""

    place: Annotated[str, PLACE]


@dataclass(frozen=True)
class Place(Request):
    """The robot stands at room `room`'s point (the dock's for `dock`), facing the
    room's heading, or `heading` degrees (counter-clockwise from the map's x axis): the
    operator says so, and missions may drive from there (issue 25). Only the holder of
    the controls may say it: a wrong pose moves the robot as surely as a key."""

    room: Annotated[str, ROOM]
    heading: Annotated[float, HEADING] | None = None
    moves: ClassVar[bool] = True


@dataclass(frozen=True)
class Name(Request):
    """Rename room `room` of the floor plan `to` (§2.6.3), and save the plan."""

    room: Annotated[str, ROOM]
    to: Annotated[str, ROOM]


@dataclass(frozen=True)
class StartMapping(Request):
    """Map the building as the operator drives it (issue 29): the range sensor's
    revolutions laid into a grid, `mark ROOM` naming the room the robot stands in. Only
    the holder of the controls may map, save or throw the map away: saving places the
    robot where the map has it, which moves it as surely as a key."""

    moves: ClassVar[bool] = True
    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class SaveMap(Request):
    """Finish mapping: write the map (`to`-map.yaml and .pgm, as ROS map_server reads
    them), the floor plan made from it (`to`.yaml: rooms and doors found, the marked
    names kept), and plan on that from now on."""

    to: Annotated[Path, PATH]
    moves: ClassVar[bool] = True


@dataclass(frozen=True)
class DiscardMap(Request):
    """Stop mapping, and throw the map away."""

    moves: ClassVar[bool] = True
    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Done(Request):
    """Finish teaching and save the route."""

    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Routes(Request):
    """List the taught routes and the patrols."""

    quick: ClassVar[bool] = True


# -- who drives -----------------------------------------------------------------------


@dataclass(frozen=True)
class TakeControls(Request):
    """Take the controls from whoever holds them (the console asks its operator first)."""

    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Heartbeat(Request):
    """A console is still there: the holder's keep the controls theirs."""

    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Status(Request):
    """What runs: the mission, who holds the controls, the last mission's end."""

    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class View(Request):
    """Send this console the camera's frames (`on`), or stop: an attached console that
    shows the camera pane asks (camera/shared_frame.py)."""

    on: bool
    quick: ClassVar[bool] = True


# Who a program on the virtual port is to the service and the consoles (service/
# virtual_port.py): it holds the controls as a console does.
PROGRAM = "the program on the virtual port"


@dataclass(frozen=True)
class HandControls(Request):
    """Hand the controls to the program on the virtual port (§4.5): the operator lets it
    drive; the keys the console held let go."""

    to: Annotated[str, CONSOLE] = PROGRAM
    moves: ClassVar[bool] = True
    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Release(Request):
    """Let what an operator's stop held (a program on the virtual port, the fleet) move
    the robot again; the console that says it lets go of the controls, handing the robot
    back."""

    moves: ClassVar[bool] = True
    quick: ClassVar[bool] = True


@dataclass(frozen=True)
class Shutdown(Request):
    """Stop the robot, then end the daemon (`giraff-console stop --daemon`)."""

    quick: ClassVar[bool] = True


REQUESTS: tuple[type[Request], ...] = (
    Press, Halt, Speed, Send, SendCommands, Stalk, Poll, Go, RunPatrol, Follow, Replay,
    Undock, Pause, Resume, StopMission, Door, Block, Record, Play, Seek, Rate, Step, Teach, Mark,
    Place, Name, Done, Routes, TakeControls, HandControls, Heartbeat, Status, Release,
    Shutdown, View, StartMapping, SaveMap, DiscardMap,
)  # fmt: skip


# -- typed ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Typed:
    """One command as it is typed: its first word, how to type it, what it does, and
    how the rest of the line becomes the command (Usage if it does not)."""

    word: str
    usage: str
    help: str
    parse: Callable[[str], Request]


def _name(what: str) -> Callable[[str], str]:
    def name(rest: str) -> str:
        if not rest:
            raise Usage(f"usage: {what}")
        return rest

    return name


def _number(rest: str, usage: str) -> float:
    try:
        value = float(parse_number(rest))
    except CommandError:
        raise Usage(f"usage: {usage}") from None
    if not math.isfinite(value):
        raise Usage(f"usage: {usage}")
    return value


def _point(rest: str, usage: str) -> tuple[float, float]:
    parts = rest.split()
    if len(parts) != 2:
        raise Usage(f"usage: {usage} (metres, map frame)")
    return _number(parts[0], usage), _number(parts[1], usage)


def _stalk(rest: str) -> Stalk:
    usage = "stalk up, stalk down or stalk N (0 to 1000)"
    if rest in ("up", "down"):
        return Stalk(step=1 if rest == "up" else -1)
    value = _number(rest, usage)
    if value != int(value) or not 0 <= value <= 1000:
        raise Usage(f"usage: {usage}")
    return Stalk(to=int(value))


def _record(rest: str) -> Record:
    if rest not in ("", "stop"):
        raise Usage("usage: record, or record stop")
    return Record(on=rest != "stop")


def _play(rest: str) -> Play:
    if rest == "stop":
        return Play(stop=True)
    try:
        # Resolved here, where it was typed: a daemon has a folder of its own.
        return Play(session=Path(rest).expanduser().resolve() if rest else None)
    except RuntimeError as error:  # ~nosuchuser
        raise Usage(f"not playing: {error}") from None


def _patrol(rest: str) -> Request:
    verbs: dict[str, Request] = {"pause": Pause(), "resume": Resume(), "stop": StopMission()}
    return verbs.get(rest) or RunPatrol(_name("patrol NAME, or patrol pause|resume|stop")(rest))


def _place(rest: str) -> Place:
    usage = "place ROOM [DEGREES] (place dock; place kitchen 90)"
    parts = rest.split()
    if not 1 <= len(parts) <= 2:
        raise Usage(f"usage: {usage}")
    heading = _number(parts[1], usage) if len(parts) == 2 else None
    return Place(parts[0], heading)


def _map(rest: str) -> Request:
    usage = "map, map save NAME, or map discard"
    word, _, name = rest.partition(" ")
    if not rest:
        return StartMapping()
    if word == "discard" and not name:
        return DiscardMap()
    if word == "save" and name.strip():
        try:
            # Resolved here, where it was typed: a daemon has a folder of its own.
            return SaveMap(Path(name.strip()).expanduser().resolve())
        except RuntimeError as error:  # ~nosuchuser
            raise Usage(f"map save: {error}") from None
    raise Usage(f"usage: {usage}")


def _rename(rest: str) -> Name:
    parts = rest.split()
    if len(parts) != 2:
        raise Usage("usage: name ROOM NEW (name room-3 kitchen)")
    return Name(*parts)


def _bare(request: Request, word: str) -> Callable[[str], Request]:
    def parse(rest: str) -> Request:
        if rest:
            raise Usage(f"usage: {word} (nothing after it)")
        return request

    return parse


TYPED: tuple[Typed, ...] = (
    Typed("stop", "stop", "let go of the keys and stop the robot now", _bare(Halt(), "stop")),
    Typed("speed", "speed X", "set the driving speed in m/s, within the configured cap",
          lambda rest: Speed(to=_number(rest, "speed 0.3"))),
    Typed("stalk", "stalk up|down|N", "raise or lower the head's stalk a step, or set it "
          "0-1000 (g, v)", _stalk),
    Typed("poll", "poll [on|off]", "the automatic odometry poll on or off (also a)",
          lambda rest: Poll(on={"on": True, "off": False}.get(rest))),
    Typed("record", "record, record stop", "record a session into recordings/ (also r)",
          _record),
    Typed("play", "play [DIR], play stop", "play the newest session, or DIR, back; stop it "
          "(also p)", _play),
    Typed("pause", "pause, resume", "hold the robot where it is on its way, and go on (also "
          "playbacks)", _bare(Pause(), "pause")),
    Typed("resume", "resume", "go on after a pause", _bare(Resume(), "resume")),
    Typed("seek", "seek S", "move the playback to S seconds in",
          lambda rest: Seek(to=_number(rest, "seek 12.5"))),
    Typed("rate", "rate X", "play back at X times real speed, 0.25 to 16",
          lambda rest: Rate(to=_number(rest, "rate 4"))),
    Typed("teach", "teach NAME", "teach a route by driving it; `mark PLACE` names places",
          lambda rest: Teach(_name("teach NAME")(rest))),
    Typed("mark", "mark PLACE", "name the place where the robot stands: on the route taught, "
          "else the room it is in (while mapping, when the map is saved)",
          lambda rest: Mark(_name("mark PLACE")(rest))),
    Typed("map", "map, map save NAME, map discard", "map the building as you drive it round "
          "(a range sensor); `mark ROOM` in each room; save writes NAME.yaml and plans on it",
          _map),
    Typed("name", "name ROOM NEW", "rename a room of the floor plan, and save the plan",
          _rename),
    Typed("place", "place ROOM [DEG]", "the robot stands at ROOM's point (dock: on the dock), "
          "facing its heading or DEG: missions may drive from there", _place),
    Typed("done", "done", "save the route being taught", _bare(Done(), "done")),
    Typed("routes", "routes", "list the taught routes and the patrols", _bare(Routes(), "routes")),
    Typed("replay-route", "replay-route NAME", "drive a taught route again, open-loop (keys "
          "or Space stop it)", lambda rest: Replay(_name("replay-route NAME")(rest))),
    Typed("follow-route", "follow-route NAME", "drive a taught route's path closed-loop, like "
          "go (from its start)", lambda rest: Follow(_name("follow-route NAME")(rest))),
    Typed("patrol", "patrol NAME, patrol pause|resume|stop", "run routes/NAME.patrol.yaml "
          "(else the example of that name shipped with the package); hold or end it", _patrol),
    Typed("undock", "undock", "back out of the dock and turn round (also u, then y)",
          _bare(Undock(), "undock")),
    Typed("go", "go ROOM", "drive to ROOM: the route is planned, shown on the map and driven",
          lambda rest: Go(_name("go ROOM")(rest))),
    Typed("close", "close DOOR, open DOOR", "shut or open a door (in the simulator too); "
          "routes go round", lambda rest: Door(_name("close DOOR")(rest), open=False)),
    Typed("open", "open DOOR", "open a door again", lambda rest: Door(_name("open DOOR")(rest),
                                                                        open=True)),
    Typed("block", "block X Y, unblock X Y", "simulator: put a box in the way at X, Y "
          "metres, or take it", lambda rest: Block(*_point(rest, "block X Y"))),
    Typed("unblock", "unblock X Y", "simulator: take a box away",
          lambda rest: Block(*_point(rest, "unblock X Y"), on=False)),
    Typed("take", "take", "take the controls from the console that holds them (asks first)",
          _bare(TakeControls(), "take")),
    Typed("status", "status", "what runs, who holds the controls, how the last mission ended",
          _bare(Status(), "status")),
    Typed("give", "give", "hand the controls to the program on the virtual port",
          _bare(HandControls(), "give")),
    Typed("release", "release", "let the program on the virtual port and the fleet move the "
          "robot again after a stop; the controls are freed", _bare(Release(), "release")),
)  # fmt: skip
BY_WORD = {typed.word: typed for typed in TYPED}
# What the help screen lists: one line for a pair typed alike (close/open, pause/resume).
HELP_LINES = [(t.usage, t.help) for t in TYPED if t.word not in ("open", "resume", "unblock")]


def parse(text: str) -> Request | None:
    """The command `text` types, or None when its first word is none of the table's
    (a controller command, for the caller to send as such); Usage if it is one typed
    wrongly."""
    word, _, rest = text.strip().partition(" ")
    typed = BY_WORD.get(word)
    if typed is None:
        return None
    return typed.parse(rest.strip())
