"""The board the robot is driven through, and the control loop on it: a real port by
name, or the one built-in simulator in the process (its URL, and its board made with or
without the random faults); the loop on the settings file's rates and limits; the route
book and the pose kept beside it. Parts of the composition root (runtime/robot.py).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import serial

from giraff_console.clock import Clock
from giraff_console.data_folders import data_home, example_routes, patrol_runs
from giraff_console.link import BoardLink
from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.missions.route_book import RouteBook
from giraff_console.missions.sessions import Sessions
from giraff_console.robot.control_loop import Connect, ControlLoop
from giraff_console.robot.deadman import Deadman
from giraff_console.robot.localisation import PoseBasis
from giraff_console.robot.pose_keeper import PoseKeeper, PoseKeeperError, read_kept
from giraff_console.robot.teleop import Teleop
from giraff_console.runtime.simulator_url import simulator_url
from giraff_console.settings import Settings
from giraff_console.sim import GiraffBoard


def board_connector(port: str | None, settings: Settings,
                    simulator: serial.SerialBase | None) -> Connect:  # fmt: skip
    """How the control loop (re)connects: a real port by name, or the one simulator."""
    if port is not None:
        return lambda: BoardLink.open(
            port, timeout=settings.timeout, power_line=settings.power_line
        )
    assert simulator is not None

    def connect() -> BoardLink:
        if not simulator.is_open:
            simulator.open()
        # On the simulator's clock: a virtual one, under --sim-speed, is the loop's too.
        link = BoardLink(simulator, timeout=settings.timeout, clock=simulator.clock)
        link.handshake(power_line="none")
        return link

    return connect


def control_loop(connect: Connect, settings: Settings, clock: Clock) -> ControlLoop:
    """The control loop on the settings' rate, teleop limits, deadman and board."""
    return ControlLoop(
        connect,
        teleop=Teleop(settings.teleop.limits()),
        deadman=Deadman(clock, settings.teleop.grace, settings.teleop.repeat_timeout),
        rate_hz=settings.control_rate,
        clock=clock,
        wheel_base=settings.board.wheel_base,
        odometers=settings.board.odometers,
        twm=settings.board.twm,
    )


def route_book(control: ControlLoop, sessions: Sessions, routes: Path, drives: DriveSetup,
               settings: Settings) -> RouteBook:  # fmt: skip
    """The routes and patrols in `routes` (then the example patrols shipped with the
    package), their runs logged where `patrols` lists them, what they say told to
    whoever listens to the loop."""
    return RouteBook(control, sessions, routes, control.note, drives,
                     settings.battery.levels(), settings.teleop.undock_distance,
                     runs=patrol_runs(), examples=example_routes())  # fmt: skip


# Where a real robot's last pose estimate is kept (robot/pose_keeper.py).
KEPT_POSE = "pose.json"


def keep_the_pose(control: ControlLoop, plan: Path) -> PoseKeeper:
    """A real robot's last estimate on the floor plan `plan`, read back as an assumption
    and placed, if there is one; and kept from now on (robot/pose_keeper.py). Before the
    loop starts."""
    path = data_home() / KEPT_POSE
    try:
        kept = read_kept(path, plan)
    except PoseKeeperError as error:
        control.note(f"{error}: taking the robot to be on its dock, unconfirmed")
        kept = None
    if kept is not None:
        control.place(kept.pose, PoseBasis.ASSUMED, kept.as_assumed())
        pose = kept.pose
        control.note(f"pose: last believed at ({pose.x:.2f}, {pose.y:.2f}), "
                     f"{pose.heading_deg:.0f}°; unconfirmed until a marker says so")  # fmt: skip
    keeper = PoseKeeper(path, plan)
    control.subscribe(keeper.hear)
    return keeper


def built_in_simulator(firmware: str | None, seed: int | None, faults: bool) -> serial.SerialBase:
    """The built-in simulator on a virtual clock, its board made here so that the
    imperfections can leave out the random stalls and ESTOPs (`--faults off`)."""
    url = simulator_url(firmware, virtual_clock=True, imperfect_seed=seed)
    simulator = serial.serial_for_url(url, do_not_open=True)
    config, _ = simulator.from_url(url)  # also gives the port its virtual clock
    if not faults:
        quiet = replace(config.imperfections, stall_rate=0.0, estop_rate=0.0)
        config = replace(config, imperfections=quiet)
    simulator.board = GiraffBoard(simulator.clock, config)
    simulator.open()
    return simulator
