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
The [teleop] and [motion] tables:

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
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path

from giraff_console.data_folders import config_path
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
from giraff_console.robot.wheel_odometers import AUTO, CHOICES

# Larger than any setting's sensible value, small enough that no check overflows.
MAX_NUMBER = 1e6
# Settings that name a folder; data_folders.py says where they are without them.
FOLDER_KEYS = ("recordings", "routes")
# Settings whose value is text.
# What a program on the virtual port may do (serve --virtual-port, docs/daemon.md):
# drive when nobody else holds the controls, or only read.
VIRTUAL_PORT_CHOICES = ("drives", "reads")
# What an order under way does when the broker goes (docs/fleet.md).
BROKER_LOST_CHOICES = ("carry_on", "stop")
LIDAR_TEXT_KEYS = ("port",)
FLEET_TEXT_KEYS = ("broker", "ca_file", "credentials", "manufacturer", "serial_number",
                   "interface", "on_broker_lost")  # fmt: skip
TEXT_KEYS = ("port", "power_line", "odometers", "twm", "virtual_port", *FOLDER_KEYS,
             *FLEET_TEXT_KEYS)  # fmt: skip
# Tables within the file, each its own dataclass below.
TABLES = ("teleop", "motion", "board", "battery", "fleet", "lidar")
# The baud rates an RPLIDAR's USB adapter runs at (A1, A2M8: 115200; later A2: 256000).
LIDAR_BAUDRATES = (115200, 256000)
# The array of tables of scheduled patrols, and the keys of each.
SCHEDULE = "schedule"
SCHEDULE_KEYS = ("patrol", "every", "from", "to")


# No dock needs a longer way out than this.
MAX_UNDOCK_M = 1.0


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

    def check(self) -> None:
        """ValueError for a wheel base, a reading or a twm choice that cannot be right."""
        low, high = WHEEL_BASE_RANGE_M
        if not low <= self.wheel_base <= high:
            raise ValueError(
                f"board.wheel_base is {self.wheel_base:g} m: it must be between {low:g} and "
                f"{high:g} m (a Giraff's wheels are about 0.5 m apart)"
            )
        if self.odometers not in CHOICES:
            raise ValueError(
                f"board.odometers is {self.odometers!r}: it must be one of {', '.join(CHOICES)}"
            )
        if self.twm not in TWM_CHOICES:
            raise ValueError(
                f"board.twm is {self.twm!r}: it must be one of {', '.join(TWM_CHOICES)}"
            )


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

    def check(self) -> None:
        if self.on_broker_lost not in BROKER_LOST_CHOICES:
            raise ValueError(f"fleet.on_broker_lost must be "
                             f"{' or '.join(BROKER_LOST_CHOICES)}")  # fmt: skip

    @property
    def stops_when_broker_lost(self) -> bool:
        return self.on_broker_lost == "stop"


# The shortest range_max a lidar may be given: what it sees must reach past the robot.
LIDAR_LEAST_RANGE_M = 2.0


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

    def check(self) -> tuple[str, str] | None:
        """The key that cannot be right and why; None if all can."""
        if self.baudrate not in LIDAR_BAUDRATES:
            return "baudrate", f"must be one of {', '.join(map(str, LIDAR_BAUDRATES))}"
        if not abs(self.forward) <= 1.0:
            return "forward", "must be within 1 m of the robot's centre"
        if not abs(self.yaw) <= 180.0:
            return "yaw", "must be from -180 to 180 degrees"
        if not 0.05 <= self.range_min < self.range_max <= 40.0:
            return "range_max", "range_min and range_max must be 0.05 <= min < max <= 40 m"
        if self.range_max < LIDAR_LEAST_RANGE_M:
            # Nearer hits are the robot itself to the map (planning/map_building.py), and
            # the way ahead is looked at for metres (missions/lookout.py).
            return "range_max", f"must be at least {LIDAR_LEAST_RANGE_M:g} m"
        if not 0.05 <= self.timeout <= 10.0:
            return "timeout", "must be from 0.05 to 10 s"
        return None


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
    teleop: TeleopSettings = field(default_factory=TeleopSettings)
    motion: MotionSettings = field(default_factory=MotionSettings)
    board: BoardSettings = field(default_factory=BoardSettings)
    battery: BatterySettings = field(default_factory=BatterySettings)
    fleet: FleetSettings = field(default_factory=FleetSettings)
    lidar: LidarSettings = field(default_factory=LidarSettings)
    schedule: tuple[ScheduledPatrol, ...] = ()
    source: str = "built-in defaults"

    @property
    def port_program_drives(self) -> bool:
        """Whether a program on the virtual port may take the controls and drive."""
        return self.virtual_port == VIRTUAL_PORT_CHOICES[0]


def load_settings(path: Path | None = None) -> Settings:
    """Read the settings file if there is one; SettingsError for anything wrong in it."""
    path = path or config_path()
    if not path.exists():
        return Settings()
    try:
        text = path.read_text(encoding="utf-8")
        data = tomllib.loads(text)
    except (OSError, ValueError) as error:
        # ValueError: TOMLDecodeError, UnicodeDecodeError, and an int of 5,000 digits.
        raise SettingsError(f"{path}: {str(error)[:200]}") from None
    schedule = _schedule(path, text, data.pop(SCHEDULE, []))
    tables = {table: data.pop(table, {}) for table in TABLES}
    for table, value in tables.items():
        if not isinstance(value, dict):
            raise SettingsError(f"{path}: [{table}] must be a table")
    try:
        teleop = TeleopSettings(**_checked(path, "teleop.", TeleopSettings, tables["teleop"]))
        motion = MotionSettings(**_checked(path, "motion.", MotionSettings, tables["motion"]))
        board = BoardSettings(**_checked(path, "board.", BoardSettings, tables["board"]))
        battery = BatterySettings(**_checked(path, "battery.", BatterySettings, tables["battery"]))
        fleet = FleetSettings(**_fleet_files(path, _checked(path, "fleet.", FleetSettings,
                                                            tables["fleet"])))  # fmt: skip
        lidar = _lidar(path, text, tables["lidar"])
        settings = Settings(**_checked(path, "", Settings, data), teleop=teleop, motion=motion,
                            board=board, battery=battery, fleet=fleet, lidar=lidar,
                            schedule=schedule,
                            source=str(path))  # fmt: skip
        if settings.power_line not in ("dtr", "rts", "both", "none"):
            raise ValueError("power_line must be dtr, rts, both or none")
        if settings.virtual_port not in VIRTUAL_PORT_CHOICES:
            raise ValueError(f"virtual_port must be {' or '.join(VIRTUAL_PORT_CHOICES)}")
        if settings.timeout <= 0 or settings.control_rate <= 0 or settings.robot_radius <= 0:
            raise ValueError("timeout, control_rate and robot_radius must be positive")
        teleop.limits()
        if teleop.grace <= 0 or teleop.repeat_timeout <= 0:
            raise ValueError("grace and repeat_timeout must be positive")
        # The console streams the undock in steps within its reach (missions/undock.py),
        # so the distance is bounded only by what a dock needs.
        if not 0 < teleop.undock_distance <= MAX_UNDOCK_M:
            raise ValueError(f"undock_distance must be in (0, {MAX_UNDOCK_M}] m")
        motion.limits()
        if motion.v_max > teleop.max_speed or motion.a_max > teleop.accel:
            raise ValueError(
                "motion.v_max and motion.a_max may not exceed teleop's max_speed and accel: "
                "every move is checked against those"
            )
        if motion.sensing_range <= 0:
            raise ValueError("motion.sensing_range must be positive")
        motion.patience()
        board.check()
        battery.levels()
        fleet.check()
    except ValueError as error:
        raise SettingsError(f"{path}: {error}") from None
    except ArithmeticError:
        # Limits so far apart that the checks' own sums overflow or divide by nothing.
        raise SettingsError(f"{path}: the values are too extreme to check") from None
    return settings


def _checked(path: Path, prefix: str, kind: type, data: dict) -> dict:
    allowed = {f.name: f for f in fields(kind) if f.name not in (*TABLES, SCHEDULE, "source")}
    for key, value in data.items():
        if key not in allowed:
            raise SettingsError(f"{path}: unknown key {prefix}{key}")
        expected = str if key in TEXT_KEYS else (int, float)
        if not isinstance(value, expected) or isinstance(value, bool):
            raise SettingsError(f"{path}: {prefix}{key} has the wrong type")
        # TOML writes nan and inf, which pass every `<=` check without being limits; and
        # no speed, rate or time of this robot comes near a million.
        if isinstance(value, int | float) and not abs(value) <= MAX_NUMBER:
            raise SettingsError(f"{path}: {prefix}{key} is {value}, out of range")
        if key in FOLDER_KEYS:
            assert isinstance(value, str)  # a folder key is a text key, checked as one above
            if not value.strip() or "\0" in value:
                raise SettingsError(f"{path}: {prefix}{key} must name a folder")
            # Relative to the settings file, not to wherever the console is started.
            data[key] = str(path.parent / Path(value).expanduser())
    return data


def _lidar(path: Path, text: str, table: dict) -> LidarSettings:
    """The [lidar] table; SettingsError as `file:line: message` for a bad key."""
    lines = _plain_table_lines(text, "lidar")
    for key, value in table.items():
        line = lines.get(key)
        if key not in {f.name for f in fields(LidarSettings)}:
            raise SettingsError(_at(path, line, f"unknown key lidar.{key}"))
        expected = str if key in LIDAR_TEXT_KEYS else int if key == "baudrate" else (int, float)
        if not isinstance(value, expected) or isinstance(value, bool):
            raise SettingsError(_at(path, line, f"lidar.{key} has the wrong type"))
        if isinstance(value, int | float) and not abs(value) <= MAX_NUMBER:
            raise SettingsError(_at(path, line, f"lidar.{key} is {value}, out of range"))
    lidar = LidarSettings(**table)
    wrong = lidar.check()
    if wrong is not None:
        key, why = wrong
        raise SettingsError(_at(path, lines.get(key, lines.get("")), f"lidar.{key} {why}"))
    return lidar


def _plain_table_lines(text: str, name: str) -> dict[str, int]:
    """The lines of a `[name]` table's keys, and of its header (key ""): tomllib keeps
    no lines, so they are found in the text, as _table_lines finds a [[schedule]]'s."""
    header = re.compile(rf"\s*\[\s*{re.escape(name)}\s*\]\s*(#.*)?\Z")
    key = re.compile(r"""\s*([A-Za-z0-9_-]+)\s*=""")
    found: dict[str, int] = {}
    inside = False
    for number, line in enumerate(text.split("\n"), start=1):
        if header.match(line):
            inside = True
            found[""] = number
        elif line.lstrip().startswith("["):
            inside = False
        elif inside and (match := key.match(line)):
            found.setdefault(match.group(1), number)
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
