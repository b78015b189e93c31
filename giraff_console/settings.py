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
"""

from __future__ import annotations

import os
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path

from giraff_console.link import DEFAULT_TIMEOUT_S
from giraff_console.missions.progress_watch import Patience
from giraff_console.motion.speed_profile import MotionLimits
from giraff_console.planning.route_planner import ROBOT_RADIUS_M
from giraff_console.protocol.errors import GiraffError
from giraff_console.robot.control_loop import DEFAULT_RATE_HZ
from giraff_console.robot.deadman import DEFAULT_GRACE_S, DEFAULT_REPEAT_TIMEOUT_S
from giraff_console.robot.teleop import DriveLimits

# Larger than any setting's sensible value, small enough that no check overflows.
MAX_NUMBER = 1e6
# Settings that name a folder; data_folders.py says where they are without them.
FOLDER_KEYS = ("recordings", "routes")


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
class Settings:
    port: str | None = None
    power_line: str = "dtr"
    timeout: float = DEFAULT_TIMEOUT_S
    control_rate: float = DEFAULT_RATE_HZ
    robot_radius: float = ROBOT_RADIUS_M
    recordings: str | None = None
    routes: str | None = None
    teleop: TeleopSettings = field(default_factory=TeleopSettings)
    motion: MotionSettings = field(default_factory=MotionSettings)
    source: str = "built-in defaults"


def config_path() -> Path:
    base = os.environ.get("XDG_CONFIG_HOME") or os.path.join(os.path.expanduser("~"), ".config")
    return Path(base) / "giraff-console" / "config.toml"


def load_settings(path: Path | None = None) -> Settings:
    """Read the settings file if there is one; SettingsError for anything wrong in it."""
    path = path or config_path()
    if not path.exists():
        return Settings()
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        # ValueError: TOMLDecodeError, UnicodeDecodeError, and an int of 5,000 digits.
        raise SettingsError(f"{path}: {str(error)[:200]}") from None
    teleop_data = data.pop("teleop", {})
    motion_data = data.pop("motion", {})
    for table, value in (("teleop", teleop_data), ("motion", motion_data)):
        if not isinstance(value, dict):
            raise SettingsError(f"{path}: [{table}] must be a table")
    try:
        teleop = TeleopSettings(**_checked(path, "teleop.", TeleopSettings, teleop_data))
        motion = MotionSettings(**_checked(path, "motion.", MotionSettings, motion_data))
        settings = Settings(**_checked(path, "", Settings, data), teleop=teleop, motion=motion,
                            source=str(path))  # fmt: skip
        if settings.power_line not in ("dtr", "rts", "both", "none"):
            raise ValueError("power_line must be dtr, rts, both or none")
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
    except ValueError as error:
        raise SettingsError(f"{path}: {error}") from None
    except ArithmeticError:
        # Limits so far apart that the checks' own sums overflow or divide by nothing.
        raise SettingsError(f"{path}: the values are too extreme to check") from None
    return settings


def _checked(path: Path, prefix: str, kind: type, data: dict) -> dict:
    allowed = {f.name: f for f in fields(kind) if f.name not in ("teleop", "motion", "source")}
    for key, value in data.items():
        if key not in allowed:
            raise SettingsError(f"{path}: unknown key {prefix}{key}")
        expected = str if key in ("port", "power_line", *FOLDER_KEYS) else (int, float)
        if not isinstance(value, expected) or isinstance(value, bool):
            raise SettingsError(f"{path}: {prefix}{key} has the wrong type")
        # TOML writes nan and inf, which pass every `<=` check without being limits; and
        # no speed, rate or time of this robot comes near a million.
        if isinstance(value, int | float) and not abs(value) <= MAX_NUMBER:
            raise SettingsError(f"{path}: {prefix}{key} is {value}, out of range")
        if key in FOLDER_KEYS and (not value.strip() or "\0" in value):
            raise SettingsError(f"{path}: {prefix}{key} must name a folder")
        if key in FOLDER_KEYS:
            # Relative to the settings file, not to wherever the console is started.
            data[key] = str(path.parent / Path(value).expanduser())
    return data
