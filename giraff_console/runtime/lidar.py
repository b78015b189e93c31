"""The lidar the options and settings ask for, read on its own thread (lidar/reader.py).

`--lidar PORT` names one; `--lidar` alone is the simulator's own with `--sim` (its
bytes through the same reading code, from the in-process `giraff-lidar://` port), and
the settings file's `[lidar] port` on a real robot, which is also used when `--lidar`
is not given. The simulator has none unless asked: the robot then senses through the
simulator's range finder, as before.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import serial

from giraff_console.lidar import SIMULATED_LIDAR
from giraff_console.lidar.device import Opener, open_named
from giraff_console.lidar.reader import LidarReader, ReaderSettings
from giraff_console.lidar.scan import Mount
from giraff_console.runtime.options import RobotOptions, UsageError
from giraff_console.runtime.sim_site import SimulatedSite
from giraff_console.settings import LidarSettings
from giraff_console.sim.lidar_port import lidar_url

SIMULATED_NAME = "simulated lidar"


def lidar_reader(options: RobotOptions, settings: LidarSettings, site: SimulatedSite | None,
                 notes: Callable[[str], None],
                 clock: Callable[[], float]) -> LidarReader | None:  # fmt: skip
    """The reader of the lidar asked for, not started; None without one. Its
    revolutions are stamped by `clock`, the control loop's, so that each is placed at
    the pose the loop had then (missions/mapping.py)."""
    asked = options.lidar
    reading = ReaderSettings(Mount(settings.forward, math.radians(settings.yaw)),
                             settings.range_min, settings.range_max, settings.timeout)  # fmt: skip
    if asked == SIMULATED_LIDAR and site is not None:
        # The simulated lidar sits at the robot's centre, facing ahead.
        reading = ReaderSettings(Mount(), settings.range_min, settings.range_max,
                                 settings.timeout)  # fmt: skip
        opener = simulated_lidar(site, options.imperfect_seed, settings.timeout)
        return LidarReader(opener, SIMULATED_NAME, settings.baudrate, reading, notes, clock)
    if asked == SIMULATED_LIDAR or (asked is None and not options.simulated):
        if not settings.port:
            if asked is None:
                return None
            raise UsageError(
                "--lidar: give its port (--lidar PORT), or [lidar] port in "
                "the settings file; only the simulator has its own (--sim)"
            )
        asked = settings.port
    if asked is None:
        return None
    return LidarReader(open_named(asked, settings.baudrate, settings.timeout), asked,
                       settings.baudrate, reading, notes, clock)  # fmt: skip


def simulated_lidar(site: SimulatedSite, seed: int | None, timeout: float) -> Opener:
    """Opens the in-process simulated lidar, which sees the site's building from the
    simulated robot's true pose, on the board's clock; with `seed` (--imperfect), with
    the datasheet's range noise."""
    board = site.board

    def opener() -> serial.SerialBase:
        port = serial.serial_for_url(lidar_url(seed=seed), do_not_open=True, timeout=timeout)
        port.world = site.lidar_world()
        port.clock = board.clock.now
        port.open()
        return port

    return opener
