"""Console settings: built-in defaults, overridden by a TOML file, then by the command line.

The file is `$XDG_CONFIG_HOME/giraff-console/config.toml` (usually
`~/.config/giraff-console/config.toml`). Every key is optional:

    port = "/dev/ttyS0"        # serial device or pyserial URL; none: the simulator
    power_line = "dtr"         # dtr, rts (FTDI cables), both or none
    timeout = 1.0              # seconds to wait for each reply
    control_rate = 20          # control-loop ticks per second
    robot_radius = 0.3         # metres the walls are grown by for planning
    recordings = "~/giraff/recordings"  # recorded sessions (--recordings)
    routes = "~/giraff/routes"          # taught routes and patrols (--routes)

Without `recordings` and `routes`, both live in `$XDG_DATA_HOME/giraff-console/`
(usually `~/.local/share/giraff-console/recordings` and `.../routes`). `~` is expanded,
and a relative folder is taken from this file's folder.
Every key's range is in the README's table of settings (RANGES and CHOICES here); a value
outside it is refused with the file and the key's line. The [teleop] and [motion] tables:

    [teleop]
    speed = 0.4                # m/s, the thesis's KBD_MOVE_SPEED
    max_speed = 0.4            # cap for the speed keys; the runaway rule limits it
    accel = 0.5                # m/s^2, the thesis's DEF_ACCEL
    turn_rate = 45             # degrees per second, KBD_TURN_SPEED
    grace = 0.7                # deadman: seconds after a first key press
    repeat_timeout = 0.15      # deadman: seconds between key repeats
    undock_distance = 0.3      # metres backed out by u (or `undock`), at most 1 m

    [motion]                   # how `go` drives
    v_max = 0.4                # m/s, at most teleop's max_speed
    a_max = 0.5                # m/s^2, at most teleop's accel
    j_max = 1.0                # m/s^3
    lateral_accel = 0.3        # m/s^2 in turns
    door_speed = 0.3           # m/s through doorways
    sensing_range = 1.5        # metres the simulated range finder sees
    stuck_s = 30               # seconds without getting 0.2 m nearer: go gives up, stops
    max_replans = 5            # new ways in a row without getting nearer: the same

The [board] and [battery] tables, for real boards (docs/simulator.md lists the firmware):

    [board]
    wheel_base = 0.499         # metres between the drive wheels, 0.2 to 1: the thesis's
                               # figure; one driver uses 0.467. The heading is integrated
                               # with it.
    odometers = "auto"         # how the wheels' travel is read: "totals" (imdl/imdr since
                               # power-up, the thesis's board), "increments" (since the
                               # previous read, later boards), "encoders" (enc0/enc1), or
                               # "auto": increments when the board answers to enc0,
                               # charger_data or twm, totals otherwise (a height stalk
                               # alone says nothing). Encoders on a board without them:
                               # reported, and auto's choice is read. Whatever it says is
                               # checked against cdis in the first metre driven: a reading
                               # that disagrees is replaced by one that agrees, and a
                               # mission under way is stopped; if none agrees, the
                               # pose is not trusted: missions are stopped and refused
                               # until a later check (a metre driven by hand) passes.
    twm = "auto"               # curves as one `set twm` (Giraff-X): "auto" when the board
                               # answers `get twm` (an assumption: wire-facts has only
                               # `set twm`, and only our simulator is known to answer the
                               # get), "on" whatever it answers, "off" never.

    [battery]                  # later boards, which report their charger
    low = 25                   # percent: below it a patrol goes to the dock to charge
    charged = 90               # percent: at or above it, it carries on

The [fleet] table: `giraff-console serve` as a VDA 5050 vehicle (docs/fleet.md):

    [fleet]
    broker = "mqtts://fleet.example:8883"  # mqtt:// or mqtts:// (TLS); none: no fleet
                               # link unless `serve --fleet URL` asks for one
    ca_file = "/etc/giraff/fleet-ca.pem"   # the CA of the broker's certificate (TLS);
                               # without it, the system's
    credentials = "/etc/giraff/fleet.cred" # one line user:password, owner-only (chmod 600)
    manufacturer = "giraff"
    serial_number = "giraff-07"  # without it, the machine's host name
    interface = "uagv"         # the first level of every topic
    on_broker_lost = "carry_on"  # an order under way when the broker goes: "carry_on"
                               # (the standard's default) or "stop"

The [lidar] table: a Slamtec RPLIDAR (A1/A2) on its own serial port (docs/simulator.md);
without a port the robot senses as before, through the simulator's range finder alone:

    [lidar]
    port = "/dev/ttyUSB0"      # device or pyserial URL; none: no lidar (--lidar PORT)
    baudrate = 115200          # A1 and A2M8; 256000 for later A2s
    forward = 0.0              # metres the sensor sits ahead of the robot's centre
    yaw = 0.0                  # degrees its front is turned left of the robot's
    range_min = 0.15           # metres: nearer returns are not measurements
    range_max = 12.0           # metres: farther ones neither
    timeout = 1.0              # seconds each read waits before the sensor is lost

Scheduled patrols, which `giraff-console serve` runs (docs/daemon.md); one [[schedule]]
table each, as many as wanted:

    [[schedule]]
    patrol = "night"           # a patrol in the routes folder (night.patrol.yaml)
    every = "2h"               # also "90m", "1h30m"; at least 10m, at most 24h
    from = "22:00"             # local time; without from and to: all day
    to = "06:00"               # the window may wrap midnight; from = to: all day

It runs at `from`, then every `every` after it while in the window, `to` included when
it falls on that grid: 22:00, 00:00, 02:00, 04:00 and 06:00 here (missions/schedule.py).
A run due while the last one of the same patrol is still going is skipped, and logged.

`max_consoles` bounds the consoles attached to `serve` at once, and the [limits] table
raises (or lowers) the limits on the files the console reads (file_limits.py, each a
positive whole number; the README lists them):

    max_consoles = 64          # 1 to 1000

    [limits]
    file_bytes = 67108864      # any one file read whole
    image_pixels = 40000000    # a grid image, read from its header

The file itself is read within bounds, before TOML is parsed: a regular file of at most
MAX_FILE_BYTES, nested at most MAX_NESTING deep. A device, a FIFO or a symlink to
/dev/zero is refused by its type without being opened for reading (a FIFO's open would
wait for a writer).
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import NoReturn

from giraff_console.data_folders import config_path
from giraff_console.file_limits import FileLimits, read_at_most
from giraff_console.link import DEFAULT_TIMEOUT_S
from giraff_console.missions.docking import ChargeLevels
from giraff_console.missions.progress_watch import Patience
from giraff_console.missions.schedule import ScheduledPatrol, ScheduleEntryError, scheduled_patrol
from giraff_console.motion.speed_profile import MotionLimits
from giraff_console.planning.route_planner import ROBOT_RADIUS_M
from giraff_console.protocol.errors import GiraffError
from giraff_console.protocol.kinematics import WHEEL_BASE_M, WHEEL_BASE_RANGE_M
from giraff_console.robot.control_loop import DEFAULT_RATE_HZ
from giraff_console.robot.deadman import DEFAULT_GRACE_S, DEFAULT_REPEAT_TIMEOUT_S
from giraff_console.robot.odometry_feed import TWM_CHOICES
from giraff_console.robot.teleop import DriveLimits
from giraff_console.robot.wheel_odometers import AUTO
from giraff_console.robot.wheel_odometers import CHOICES as ODOMETER_CHOICES

# Settings that name a folder; data_folders.py says where they are without them.
FOLDER_KEYS = ("recordings", "routes")
# What a program on the virtual port may do (serve --virtual-port, docs/daemon.md):
# drive when nobody else holds the controls, or only read.
VIRTUAL_PORT_CHOICES = ("drives", "reads")
# What an order under way does when the broker goes (docs/fleet.md).
BROKER_LOST_CHOICES = ("carry_on", "stop")
# Tables within the file, each its own dataclass below.
TABLES = ("teleop", "motion", "board", "battery", "fleet", "lidar", "limits")
# The baud rates an RPLIDAR's USB adapter runs at (A1, A2M8: 115200; later A2: 256000).
LIDAR_BAUDRATES = (115200, 256000)
# The array of tables of scheduled patrols, and the keys of each.
SCHEDULE = "schedule"
SCHEDULE_KEYS = ("patrol", "every", "from", "to")
# The shortest range_max a lidar may be given: what it sees must reach past the robot.
LIDAR_LEAST_RANGE_M = 2.0
# A hand-written settings file is a few kilobytes. It is read before [limits] is known,
# so it has a bound of its own, not file_limits'.
MAX_FILE_BYTES = 1024 * 1024
# No settings file nests past three levels (a table, an array, a value). tomllib
# recurses on nested arrays and inline tables (a RecursionError at about 1,000 levels),
# and a dotted key of 10,000 parts takes it 6 s and 400 MB; so the depth is bounded
# before it parses, as yaml_source.py does for YAML.
MAX_NESTING = 100
# The largest a [limits] value may be raised to: more than a robot's PC holds, in bytes
# or things, and small enough that no sum over such numbers loses exactness.
MAX_LIMIT = 2**40

# The control rate's range. The board talks at 115200 baud, 10 bits a byte: 11,520
# bytes a second (wire-facts, "Serial line"). A later board's poll each tick is
# `get bulk_data` (14 bytes, 150 back), `get enc0` and `get enc1` (27 bytes each, both
# ways): 218 bytes, 19 ms of the line; a move's settings and target (three `set`s, about
# 30 bytes each with their replies) take 8 ms more, 27 ms in all. At 30 Hz a tick lasts
# 33 ms and they fit with room for the gauges every half second and typed commands; at
# 40 Hz (25 ms) they would not, and the loop would run late on every tick of a move.
# The deployed drivers poll at 25-40 Hz.
MAX_RATE_HZ = 30.0
# Below, the safety rules' timing: a target lies at most REACH_M = 0.25 m ahead
# (robot/safety.py), and at 0.4 m/s and 0.5 m/s^2 the robot needs 0.16 m to brake, so
# the target must be renewed before the robot covers the 0.09 m between them; teleop
# renews it RENEW_TICKS = 2 ticks early (0.08 m at 0.1 s a tick). And a let-go key (the
# deadman's repeat timeout, 0.15 s) is acted on at the next tick: within 0.25 s at 10 Hz.
# At 0.2 Hz a tick came every 5 s and `go` never moved.
MIN_RATE_HZ = 10.0


@dataclass(frozen=True)
class Range:
    """A number's allowed values, both ends included; `unit` as the README writes it."""

    low: float
    high: float
    unit: str = ""
    whole: bool = False  # a whole number, not a fraction
    why: str = ""


# Every number a settings file may hold, by its dotted name (the README's table says the
# same). Speeds and accelerations are bounded further by the runaway rule (DriveLimits).
RANGES: dict[str, Range] = {
    # A `get` reply is 18 bytes, under 2 ms at 115200 baud; the thesis's board answers
    # in milliseconds, and a link lost for 10 s is lost.
    "timeout": Range(0.05, 10.0, "s"),
    "control_rate": Range(
        MIN_RATE_HZ,
        MAX_RATE_HZ,
        "Hz",
        why="the most the board's 115200 baud carries, the least the deadman's timing allows",
    ),
    # A Giraff is about 0.6 m across.
    "robot_radius": Range(0.1, 1.0, "m"),
    # Each console is a client the daemon serves beside the control loop (issue 30).
    "max_consoles": Range(1, 1000, whole=True),
    "teleop.speed": Range(0.05, 1.0, "m/s"),
    "teleop.max_speed": Range(0.05, 1.0, "m/s"),
    "teleop.accel": Range(0.1, 2.0, "m/s^2"),
    # At 90 degrees a second on a 0.5 m wheel base, a wheel goes 0.39 m/s.
    "teleop.turn_rate": Range(1.0, 90.0, "deg/s"),
    # The terminals' initial repeat delays are 0.5-0.66 s; repeats come every 30-40 ms.
    "teleop.grace": Range(0.1, 2.0, "s"),
    "teleop.repeat_timeout": Range(0.05, 0.5, "s"),
    # The console streams the undock in steps within its reach (missions/undock.py), so
    # the distance is bounded only by what a dock needs.
    "teleop.undock_distance": Range(0.05, 1.0, "m"),
    "motion.v_max": Range(0.05, 1.0, "m/s"),
    "motion.a_max": Range(0.05, 2.0, "m/s^2"),
    "motion.j_max": Range(0.1, 10.0, "m/s^3"),
    "motion.lateral_accel": Range(0.05, 2.0, "m/s^2"),
    "motion.door_speed": Range(0.05, 1.0, "m/s"),
    "motion.sensing_range": Range(0.2, 12.0, "m"),
    "motion.stuck_s": Range(1.0, 3600.0, "s"),
    "motion.max_replans": Range(1, 1000, whole=True),
    "board.wheel_base": Range(
        *WHEEL_BASE_RANGE_M, "m", why="a Giraff's wheels are about 0.5 m apart"
    ),
    "battery.low": Range(0.0, 100.0, "%"),
    "battery.charged": Range(0.0, 100.0, "%"),
    "lidar.forward": Range(-1.0, 1.0, "m"),
    "lidar.yaw": Range(-180.0, 180.0, "deg"),
    "lidar.range_min": Range(0.05, 40.0, "m"),
    # Nearer hits are the robot itself to the map (planning/map_building.py), and the
    # way ahead is looked at for metres (missions/lookout.py).
    "lidar.range_max": Range(LIDAR_LEAST_RANGE_M, 40.0, "m"),
    "lidar.timeout": Range(0.05, 10.0, "s"),
    # Read by their names, whatever fields file_limits.py has.
    **{f"limits.{limit.name}": Range(1, MAX_LIMIT, whole=True) for limit in fields(FileLimits)},
}
# Every text with a fixed set of values, and the one number that has one.
CHOICES: dict[str, tuple[str | int, ...]] = {
    "power_line": ("dtr", "rts", "both", "none"),
    "virtual_port": VIRTUAL_PORT_CHOICES,
    "board.odometers": ODOMETER_CHOICES,
    "board.twm": TWM_CHOICES,
    "fleet.on_broker_lost": BROKER_LOST_CHOICES,
    "lidar.baudrate": LIDAR_BAUDRATES,
}


class SettingsError(GiraffError):
    """A settings file that cannot be used; the message names the file and the key."""


@dataclass(frozen=True)
class TeleopSettings:
    speed: float = 0.4
    max_speed: float = 0.4
    accel: float = 0.5
    turn_rate: float = 45.0
    grace: float = DEFAULT_GRACE_S
    repeat_timeout: float = DEFAULT_REPEAT_TIMEOUT_S
    undock_distance: float = 0.3

    def limits(self) -> DriveLimits:
        return DriveLimits(
            speed=self.speed, max_speed=self.max_speed, accel=self.accel, turn_rate=self.turn_rate
        )


@dataclass(frozen=True)
class MotionSettings:
    v_max: float = 0.4
    a_max: float = 0.5
    j_max: float = 1.0
    lateral_accel: float = 0.3
    door_speed: float = 0.3
    sensing_range: float = 1.5
    stuck_s: float = Patience.stuck_s
    max_replans: int = Patience.max_replans

    def patience(self) -> Patience:
        """How long `go` and `follow-route` may get no nearer; ValueError if nonsense."""
        return Patience(self.stuck_s, self.max_replans)

    def limits(self) -> MotionLimits:
        """ValueError for limits that do not make sense."""
        return MotionLimits(
            v_max=self.v_max, a_max=self.a_max, j_max=self.j_max,
            lateral_accel=self.lateral_accel, door_speed=min(self.door_speed, self.v_max),
            rotation_speed=self.v_max,
        )  # fmt: skip


@dataclass(frozen=True)
class BoardSettings:
    """The robot's geometry, how its wheels' travel is read and whether curves go out as
    one twm (wire-facts, "Later firmware")."""

    wheel_base: float = WHEEL_BASE_M
    odometers: str = AUTO
    twm: str = AUTO


@dataclass(frozen=True)
class BatterySettings:
    """When a patrol goes to charge, and when it carries on (percent of a full battery)."""

    low: float = ChargeLevels.low
    charged: float = ChargeLevels.charged

    def levels(self) -> ChargeLevels:
        """ValueError for levels that do not make sense."""
        try:
            return ChargeLevels(self.low, self.charged)
        except ValueError:
            raise ValueError(
                f"battery.low ({self.low:g}) must be below battery.charged "
                f"({self.charged:g}), both percentages from 0 to 100"
            ) from None


@dataclass(frozen=True)
class FleetSettings:
    """The broker a daemon joins as a VDA 5050 vehicle, and who it is there."""

    broker: str = ""
    ca_file: str = ""
    credentials: str = ""
    manufacturer: str = "giraff"
    serial_number: str = ""
    interface: str = "uagv"
    on_broker_lost: str = BROKER_LOST_CHOICES[0]

    @property
    def stops_when_broker_lost(self) -> bool:
        return self.on_broker_lost == "stop"


@dataclass(frozen=True)
class LidarSettings:
    """The RPLIDAR, if the robot has one: where it is plugged in and where it sits."""

    port: str = ""
    baudrate: int = 115200
    forward: float = 0.0
    yaw: float = 0.0
    range_min: float = 0.15
    range_max: float = 12.0
    timeout: float = 1.0


@dataclass(frozen=True)
class Settings:
    port: str | None = None
    power_line: str = "dtr"
    timeout: float = DEFAULT_TIMEOUT_S
    control_rate: float = DEFAULT_RATE_HZ
    robot_radius: float = ROBOT_RADIUS_M
    recordings: str | None = None
    routes: str | None = None
    virtual_port: str = "drives"
    max_consoles: int = 64
    teleop: TeleopSettings = field(default_factory=TeleopSettings)
    motion: MotionSettings = field(default_factory=MotionSettings)
    board: BoardSettings = field(default_factory=BoardSettings)
    battery: BatterySettings = field(default_factory=BatterySettings)
    fleet: FleetSettings = field(default_factory=FleetSettings)
    lidar: LidarSettings = field(default_factory=LidarSettings)
    limits: FileLimits = field(default_factory=FileLimits)
    schedule: tuple[ScheduledPatrol, ...] = ()
    source: str = "built-in defaults"

    @property
    def port_program_drives(self) -> bool:
        """Whether a program on the virtual port may take the controls and drive."""
        return self.virtual_port == VIRTUAL_PORT_CHOICES[0]


def load_settings(path: Path | None = None) -> Settings:
    """Read the settings file if there is one; SettingsError for anything wrong in it,
    as `file:line: message` where the line is known."""
    path = path or config_path()
    text = _read(path)
    if text is None:
        return Settings()
    deep = _too_deep(text)
    if deep is not None:
        raise SettingsError(_at(path, deep, f"nested more than {MAX_NESTING} levels deep"))
    try:
        data = tomllib.loads(text)
    except ValueError as error:
        # TOMLDecodeError ends "(at line N, column M)"; an int of 5,000 digits is one too.
        message = str(error)[:200]
        found = re.search(r"\(at line (\d+), column \d+\)", message)
        line = int(found.group(1)) if found else None
        if "(at end of document)" in message:
            line = text.count("\n") + 1
        message = re.sub(r"\s*\(at (line|end of document).*\)", "", message)
        raise SettingsError(_at(path, line, message)) from None
    where = _Where(path, _key_lines(text))
    schedule = _schedule(path, text, data.pop(SCHEDULE, []))
    tables = {table: data.pop(table, {}) for table in TABLES}
    for table, value in tables.items():
        if not isinstance(value, dict):
            where.refuse(table, f"[{table}] must be a table")
    teleop = TeleopSettings(**where.checked("teleop.", TeleopSettings, tables["teleop"]))
    motion = MotionSettings(**where.checked("motion.", MotionSettings, tables["motion"]))
    board = BoardSettings(**where.checked("board.", BoardSettings, tables["board"]))
    battery = BatterySettings(**where.checked("battery.", BatterySettings, tables["battery"]))
    fleet = FleetSettings(**_fleet_files(path, where.checked("fleet.", FleetSettings,
                                                             tables["fleet"])))  # fmt: skip
    lidar = LidarSettings(**where.checked("lidar.", LidarSettings, tables["lidar"]))
    limits = FileLimits(**where.checked("limits.", FileLimits, tables["limits"]))
    top = where.checked("", Settings, data)
    for key in FOLDER_KEYS:
        if key in top:
            if not top[key].strip() or "\0" in top[key]:
                where.refuse(key, f"{key} must name a folder")
            # Relative to the settings file, not to wherever the console is started.
            top[key] = str(path.parent / Path(top[key]).expanduser())
    _check_together(where, teleop, motion, battery, lidar)
    return Settings(**top, teleop=teleop, motion=motion, board=board, battery=battery,
                    fleet=fleet, lidar=lidar, limits=limits, schedule=schedule,
                    source=str(path))  # fmt: skip


def _check_together(where: _Where, teleop: TeleopSettings, motion: MotionSettings,
                    battery: BatterySettings, lidar: LidarSettings) -> None:  # fmt: skip
    """The rules between keys, each in range by itself; refused at the line of the first
    of the keys that break one together."""
    try:
        teleop.limits()  # the runaway rule: the speed, the cap and the acceleration
    except ValueError as error:
        where.refuse_first(("teleop.speed", "teleop.max_speed", "teleop.accel"),
                           f"[teleop] {error}")  # fmt: skip
    if motion.v_max > teleop.max_speed or motion.a_max > teleop.accel:
        where.refuse_first(("motion.v_max", "motion.a_max", "teleop.max_speed", "teleop.accel"),
                           "motion.v_max and motion.a_max may not exceed teleop's max_speed "
                           "and accel: every move is checked against those")  # fmt: skip
    # Motion's limits and patience (MotionLimits, Patience) hold by the ranges alone.
    try:
        battery.levels()
    except ValueError as error:
        where.refuse_first(("battery.low", "battery.charged"), str(error))
    if not lidar.range_min < lidar.range_max:
        where.refuse_first(("lidar.range_min", "lidar.range_max"),
                           "lidar.range_min must be below lidar.range_max")  # fmt: skip


@dataclass(frozen=True)
class _Where:
    """The settings file and the lines of its keys, for refusals as `file:line: ...`."""

    path: Path
    lines: dict[str, int]

    def refuse(self, key: str, message: str) -> NoReturn:
        """SettingsError at `key`'s line, or its table's header, or the file."""
        table = key.rpartition(".")[0]
        line = self.lines.get(key) or self.lines.get(table) or self.lines.get(f"{key}.")
        raise SettingsError(_at(self.path, line, message))

    def refuse_first(self, keys: tuple[str, ...], message: str) -> NoReturn:
        """SettingsError at the first line of `keys` in the file."""
        found = sorted(self.lines[key] for key in keys if key in self.lines)
        raise SettingsError(_at(self.path, found[0] if found else None, message))

    def checked(self, prefix: str, kind: type, data: dict) -> dict:
        """`data`, a table of `kind`, with every key known, of its type and in range."""
        allowed = {f.name for f in fields(kind)} - {*TABLES, SCHEDULE, "source"}
        for key, value in data.items():
            name = prefix + key
            if key not in allowed:
                self.refuse(name, f"unknown key {name}")
            span, choices = RANGES.get(name), CHOICES.get(name)
            whole_choice = choices is not None and isinstance(choices[0], int)
            expected = (int, float) if span is not None else int if whole_choice else str
            if not isinstance(value, expected) or isinstance(value, bool):
                whole = whole_choice or (span is not None and span.whole)
                wanted = ("a whole number" if whole else "a number" if span is not None
                          else "a text in quotes")  # fmt: skip
                self.refuse(name, f"{name} must be {wanted}, not {_toml_kind(value)}")
            if span is not None:
                assert isinstance(value, int | float)  # a number, checked as one above
                _check_range(self, name, value, span)
            if choices is not None and value not in choices:
                self.refuse(name, f"{name} must be one of {', '.join(map(str, choices))}, "
                                  f"not {value!r}")  # fmt: skip
        return data


def _check_range(where: _Where, name: str, value: float, span: Range) -> None:
    # Whole numbers in full (a limit of 2**40 is no 1.09951e+12 to whoever raises it).
    low, high = (str(int(end)) if span.whole else f"{end:g}" for end in (span.low, span.high))
    if span.whole and not isinstance(value, int):
        where.refuse(name, f"{name} must be a whole number from {low} to {high}, not {value:g}")
    # Written so that NaN, which passes every `<=` by failing it, is refused too.
    if not span.low <= value <= span.high:
        unit = f" {span.unit}" if span.unit else ""
        why = f": {span.why}" if span.why else ""
        # An int past a float's range has no `g` form.
        shown = "a larger number" if isinstance(value, int) and abs(value) > 1e300 else f"{value:g}"
        where.refuse(name, f"{name} must be between {low} and {high}{unit}, not "
                           f"{shown}{unit}{why}")  # fmt: skip


def _read(path: Path) -> str | None:
    """The settings file's text; None if there is none; SettingsError, naming the file,
    for one that is not a regular file, too large or not UTF-8 text (by type before it
    is opened, and read no further than its bound: file_limits.read_at_most)."""
    try:
        data = read_at_most(path, MAX_FILE_BYTES, "a settings file may have")
    except FileNotFoundError:
        return None  # no file (or a symlink to none): the built-in defaults
    except (OSError, ValueError) as error:
        raise SettingsError(f"{path}: {_os_error(error)}") from None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        line = data.count(b"\n", 0, error.start) + 1
        message = f"not UTF-8 text (byte {data[error.start]:#04x})"
        raise SettingsError(_at(path, line, message)) from None


def _os_error(error: OSError | ValueError) -> str:
    return (error.strerror if isinstance(error, OSError) else None) or str(error)[:200]


def _too_deep(text: str) -> int | None:
    """The first line nested deeper than MAX_NESTING, by an upper bound on its depth:
    the brackets and braces open before it and on it, and the dots of its keys (a dotted
    key or table name is a table in a table). The dots are counted on the whole line,
    values and comments included, and brackets inside strings count too: overcounting
    only refuses sooner. A line that is only a comment nests nothing. Counted with
    str.count, so that a long file costs little."""
    flow_depth = 0
    for number, line in enumerate(text.split("\n"), start=1):
        if line.lstrip().startswith("#"):
            continue
        opens = line.count("[") + line.count("{")
        if flow_depth + opens + line.count(".") + 1 > MAX_NESTING:
            return number
        flow_depth = max(flow_depth + opens - line.count("]") - line.count("}"), 0)
    return None


def _key_lines(text: str) -> dict[str, int]:
    """The line of every key outside [[...]] arrays, by its dotted name ("teleop.speed"),
    and of every table's header ("teleop"): tomllib keeps no lines, so they are found in
    the text, as _table_lines finds a [[schedule]]'s. A good guess for the files people
    write, though a multi-line string that looks like a key would fool it."""
    header = re.compile(r"\s*\[\s*([A-Za-z0-9_-]+)\s*\]\s*(#.*)?\Z")
    # A dotted key (`deep.er = 1`) is found by its first part, the key of its table.
    key = re.compile(r"""\s*(?:"([^"]*)"|'([^']*)'|([A-Za-z0-9_-]+))\s*[=.]""")
    found: dict[str, int] = {}
    prefix: str | None = ""
    for number, line in enumerate(text.split("\n"), start=1):
        if match := header.match(line):
            prefix = match.group(1) + "."
            found.setdefault(match.group(1), number)
        elif line.lstrip().startswith("["):
            prefix = None  # an array of tables, [[schedule]], read by _table_lines
        elif prefix is not None and (match := key.match(line)):
            name = next(part for part in match.groups() if part is not None)
            found.setdefault(prefix + name, number)
    return found


def _fleet_files(path: Path, data: dict) -> dict:
    """The fleet's files, relative to the settings file as the folders are."""
    for key in ("ca_file", "credentials"):
        if data.get(key):
            data[key] = str(path.parent / Path(data[key]).expanduser())
    return data


def _schedule(path: Path, text: str, tables: object) -> tuple[ScheduledPatrol, ...]:
    """The [[schedule]] tables; SettingsError as `file:line: message` for a bad one."""
    lines = _table_lines(text, SCHEDULE)
    if not isinstance(tables, list) or not all(isinstance(t, dict) for t in tables):
        line = _key_line(text, SCHEDULE) or (lines[0][0] if lines else None)
        raise SettingsError(_at(path, line, "schedule must be tables, each one [[schedule]]"))
    entries = []
    for index, table in enumerate(tables):
        header, keys = lines[index] if index < len(lines) else (_key_line(text, SCHEDULE), {})
        where = f"schedule[{index}]"
        for key in table:
            if key not in SCHEDULE_KEYS:
                raise SettingsError(_at(path, keys.get(key, header), f"unknown key {where}.{key}"))
        try:
            entries.append(scheduled_patrol(table))
        except ScheduleEntryError as error:
            line = keys.get(error.key, header)
            raise SettingsError(_at(path, line, f"{where}.{error}")) from None
    return tuple(entries)


def _at(path: Path, line: int | None, message: str) -> str:
    """`file:line: message`, as the route and patrol files' complaints are
    (missions/yaml_file.py); `file: message` where the line is not known."""
    return f"{path}:{line}: {message}" if line else f"{path}: {message}"


def _table_lines(text: str, name: str) -> list[tuple[int, dict[str, int]]]:
    """For each `[[name]]` header in the file, its line and the lines of its keys.

    tomllib keeps no lines, so they are found in the text: a good guess for the files
    people write, though a multi-line string that looks like a header would fool it.
    """
    header = re.compile(rf"\s*\[\[\s*{re.escape(name)}\s*\]\]\s*(#.*)?\Z")
    key = re.compile(r"""\s*(?:"([^"]*)"|'([^']*)'|([A-Za-z0-9_-]+))\s*=""")
    found: list[tuple[int, dict[str, int]]] = []
    keys: dict[str, int] | None = None
    for number, line in enumerate(text.split("\n"), start=1):
        if header.match(line):
            keys = {}
            found.append((number, keys))
        elif line.lstrip().startswith("["):
            keys = None
        elif keys is not None and (match := key.match(line)):
            keys.setdefault(next(part for part in match.groups() if part is not None), number)
    return found


def _key_line(text: str, name: str) -> int | None:
    """The line of a top-level `name = ...` (before the first table), if there is one."""
    for number, line in enumerate(text.split("\n"), start=1):
        if line.lstrip().startswith("["):
            return None
        if re.match(rf"\s*{re.escape(name)}\s*=", line):
            return number
    return None


def _toml_kind(value: object) -> str:
    """What a value read from TOML is, in the file's terms."""
    if isinstance(value, bool):
        return "true or false"
    if isinstance(value, int):
        return "a whole number"
    if isinstance(value, float):
        return "a number with a decimal point"
    if isinstance(value, str):
        return "a text"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, dict):
        return "a table"
    return "a date or time"
