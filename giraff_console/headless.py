"""What `go` and `patrol` share: the robot run without the console's screen.

Both load the floor plan, connect to a board or to the built-in simulator in the plan's
building, run the same control loop the console runs, find the robot by the plan's
markers (issue 14) and drive one mission to its end, its progress on standard error.

With the simulator the loop runs on a virtual clock, `--sim-speed` times faster than
real time: every tick falls at the same virtual time whatever the speed, so a faster
clock changes nothing but how long the run takes. The simulated camera is the
localisation's eye (robot/marker_eye.py), looked through on the loop's thread between
ticks, so that its frames fall at the same virtual times too.

The simulator-only options make the tests of issue 14 possible from the shell: the
robot put down somewhere other than the dock the console assumes (`--sim-start`), a
marker that has slid along its wall but not in the plan (`--move-marker`), imperfect
odometry and casters without the random stalls and ESTOPs that end missions
(`--faults off`), and dead reckoning alone to compare with (`--no-landmarks`).
"""

from __future__ import annotations

import argparse
import math
import sys
import threading
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import rich.progress
import serial
from rich.console import Console

from giraff_console.camera.feed import CameraFeed
from giraff_console.camera_setup import camera_feed, find_the_robot
from giraff_console.clock import Clock, RealClock
from giraff_console.data_folders import default_recordings, default_routes
from giraff_console.missions.docking import DOCK
from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.missions.lookout import Sense
from giraff_console.missions.navigation import Navigator
from giraff_console.planning.floorplan import FloorPlan, FloorPlanError, Landmarks, load_floorplan
from giraff_console.planning.landmarks import fit_on_walls, marker_beliefs, marker_walls
from giraff_console.planning.route_planner import walls_of
from giraff_console.robot.last_stop import LastStop
from giraff_console.robot.localisation import PoseBasis
from giraff_console.robot.loop_events import Listener, LoopEvent, Note
from giraff_console.robot.marker_eye import EYE_FPS, EYE_SIZE, MarkerEye
from giraff_console.robot.mission import TEXT_BAR, Mission, MissionEnd, Outcome
from giraff_console.robot.odometry import Pose
from giraff_console.robot.telemetry import LinkState, Telemetry
from giraff_console.robot_setup import board_connector, control_loop, keep_the_pose
from giraff_console.settings import Settings
from giraff_console.sim import GiraffBoard
from giraff_console.sim.drive import TruePose
from giraff_console.sim_site import SimulatedSite, plan_world
from giraff_console.simulator_options import add_firmware_option, simulator_url

# How `go` and `patrol` end: arrived with the pose confirmed by a marker; not arrived;
# a mistake in the command; arrived, but by an estimate nothing confirmed (issue 25).
EXIT_ARRIVED, EXIT_FAILED, EXIT_USAGE, EXIT_UNVERIFIED = 0, 1, 2, 3
# Seconds of real time to wait for the board's first answer.
CONNECT_TIMEOUT_S = 10.0
# The options that only mean something in the simulated building.
SIM_ONLY = ("imperfect", "block", "sim_start", "move_marker", "eye_fps", "eye_size", "sim_markers")


class UsageError(Exception):
    """A mistake in the command: an option, the floor plan, a room; exit code 2."""


def add_board_options(parser: argparse.ArgumentParser, example: Path, *,
                      after_command: bool) -> None:  # fmt: skip
    """The options that say which robot and building: the console's before any command,
    and every command's that drives `after_command` (given there or before it, so their
    defaults are the console's: SUPPRESS keeps one from hiding the other)."""

    def default(value: object) -> object:
        return argparse.SUPPRESS if after_command else value

    parser.add_argument(
        "--floorplan", type=Path, default=default(None), metavar="FILE",
        help=f"the building to plan and show routes on (default: the example care home, "
        f"{example}); the robot starts in its start room; floorplans/README.md has the "
        "format",
    )  # fmt: skip
    parser.add_argument(
        "--port", metavar="PORT|URL", default=default(None),
        help="the motor board's serial device or pyserial URL (default: from the settings "
        "file; without one, the built-in simulator)",
    )  # fmt: skip
    parser.add_argument(
        "--sim", action="store_true", default=default(False),
        help="use the built-in simulator, in the floor plan's building",
    )  # fmt: skip
    parser.add_argument(
        "--sim-speed", type=float, default=default(1.0), metavar="K",
        help="run the simulator's clock K times faster than real time; inf for as fast as "
        "it can (default: 1)",
    )  # fmt: skip
    parser.add_argument(
        "--camera", metavar="DEVICE", default=default(None),
        help="camera index, device path or video file; or unix:PATH, a camera served on a "
        "Unix socket, as `sim --camera PATH` serves one (give --calibration "
        "PATH.calibration.yaml, which it writes). Default: the synthetic camera with the "
        "simulator, else camera 0; a test pattern if it is missing. Markers are found in "
        "its frames only with a calibration",
    )  # fmt: skip
    parser.add_argument(
        "--calibration", metavar="FILE", default=default(None),
        help="OpenCV fisheye calibration (camera_matrix, distortion_coefficients, "
        "image_width, image_height) to undistort the camera image and place markers",
    )  # fmt: skip
    parser.add_argument(
        "--at", metavar="ROOM[:DEG]", default=default(None),
        help="the robot stands at ROOM's point (dock: on its dock), facing the room's "
        "heading or DEG degrees: you say so, and missions set off from there (with "
        "markers in the plan they still look for one first, to confirm it). Without it, a "
        "real robot's pose is only assumed (the one it was last believed at, or the dock) "
        "until a marker confirms it, and no mission drives from an assumed pose. Never "
        "put it in a service unit that restarts the daemon",
    )  # fmt: skip
    add_firmware_option(parser, after_command=after_command)


def add_folder_options(parser: argparse.ArgumentParser, *, after_command: bool,
                       recordings: bool = True) -> None:  # fmt: skip
    """Where routes, patrols and (with `recordings`) sessions are kept."""
    default = argparse.SUPPRESS if after_command else None
    if recordings:
        parser.add_argument(
            "--recordings", type=Path, default=default, metavar="DIR",
            help="where sessions are recorded and looked for (default: the settings "
            f"file's `recordings`, else {default_recordings()})",
        )  # fmt: skip
    parser.add_argument(
        "--routes", type=Path, default=default, metavar="DIR",
        help="where taught routes and patrols are kept (default: the settings file's "
        f"`routes`, else {default_routes()})",
    )  # fmt: skip


def add_robot_options(parser: argparse.ArgumentParser, example: Path, *,
                      json: bool = True) -> None:  # fmt: skip
    """The options of every command that drives without the screen; `json` for one that
    ends and says how it went (`go`, `patrol`)."""
    add_board_options(parser, example, after_command=True)
    if json:
        parser.add_argument("--json", action="store_true", help="print how it went as JSON")
    parser.add_argument(
        "--imperfect", action="store_true",
        help="simulate a real robot's errors: distances, caster drift, stalls, ESTOP",
    )  # fmt: skip
    parser.add_argument("--seed", type=int, default=1, metavar="N", help="seed for --imperfect")
    parser.add_argument(
        "--faults", choices=("on", "off"), default="on",
        help="with --imperfect, off keeps the distance errors and caster drift but makes "
        "no random stalls or ESTOPs, which end missions by design (default: %(default)s)",
    )  # fmt: skip
    parser.add_argument(
        "--no-landmarks", action="store_true",
        help="dead reckoning only: ignore the floor plan's markers (the estimate is then "
        "the odometry's)",
    )  # fmt: skip
    parser.add_argument(
        "--block", action="append", default=[], metavar="X,Y",
        help="put a 0.5 m box in the simulated building at X,Y metres (repeatable)",
    )  # fmt: skip
    parser.add_argument(
        "--sim-start", metavar="ROOM",
        help="put the simulated robot at ROOM's point, facing its heading, instead of on "
        "the dock; the console is not told and still assumes the dock",
    )  # fmt: skip
    parser.add_argument(
        "--move-marker", action="append", default=[], metavar="ID:DX",
        help="slide the simulated building's marker ID DX metres along its wall (positive: "
        "to your right as you face it), leaving the floor plan as it is (repeatable)",
    )  # fmt: skip
    parser.add_argument(
        "--sim-markers", type=Path, metavar="FILE",
        help="hang FILE's markers (a floor plan's landmarks) in the simulated building "
        "instead of the plan's: a plan without them, or surveyed, against the true ones",
    )  # fmt: skip
    parser.add_argument(
        "--eye-fps", type=float, metavar="F",
        help=f"frames a second the simulated camera looks for markers (default: {EYE_FPS:g})",
    )  # fmt: skip
    parser.add_argument(
        "--eye-size", metavar="WxH",
        help=f"the simulated camera's frame size (default: {EYE_SIZE[0]}x{EYE_SIZE[1]})",
    )  # fmt: skip


class HeadlessRobot:
    """The floor plan, the board (or the simulator in the plan's building) and the
    control loop on it, as `args` ask; UsageError for a mistake in them. Nothing runs
    until `run`."""

    def __init__(self, args: argparse.Namespace, settings: Settings, port: str | None,
                 example: Path, *, notes: Listener | None = None,
                 surveying: Landmarks | None = None) -> None:  # fmt: skip
        """`notes`: who hears the loop's notes from the start (the daemon's journal,
        serve_command.py); by default they go to standard error, as the operator's only
        way of being told (`go`, `patrol`), so that the robot stops if that fails.
        `surveying`: a survey's markers are to be found afresh (the plan's family and
        size, else these; none known yet)."""
        if port is not None:
            given = [f"--{name.replace('_', '-')}" for name in SIM_ONLY if getattr(args, name)]
            if given:
                raise UsageError(f"{', '.join(given)}: only with the simulator (--sim)")
        if not args.sim_speed > 0:  # NaN too
            raise UsageError("--sim-speed must be positive")
        if port is None and args.at is not None:
            raise UsageError("--at: only on a real robot; the simulator's starts on its dock, "
                             "and --sim-start puts it elsewhere")  # fmt: skip
        self.surveying = surveying is not None
        try:
            self.plan = load_floorplan(args.floorplan or example)
            if surveying is not None:
                looked_for = self.plan.landmarks or surveying
                self.plan = replace(self.plan, landmarks=replace(looked_for, markers=()))
            hung = _hung_markers(self.plan, args.sim_markers)
            self.navigator = Navigator(self.plan, walls_of(self.plan), settings.robot_radius)
            self.limits = settings.motion.limits()
            self.patience = settings.motion.patience()
            blocks = [_point(text) for text in args.block]
            moved = _moved_plan(self.plan, args.move_marker)
            eye_fps = EYE_FPS if args.eye_fps is None else args.eye_fps
            eye_size = EYE_SIZE if args.eye_size is None else _size(args.eye_size)
        except (FloorPlanError, OSError, ValueError) as error:
            raise UsageError(str(error)) from None
        if not (eye_fps > 0 and math.isfinite(eye_fps)):
            raise UsageError("--eye-fps must be a positive number")
        if args.sim_start is not None and args.sim_start not in self.plan.rooms:
            raise UsageError(f"--sim-start: {self.plan.no_room(args.sim_start)}")
        self.start = self.navigator.start_pose
        self.site: SimulatedSite | None = None
        self.stepped: float | None = None
        if port is None:
            seed = args.seed if args.imperfect else None
            simulator = built_in_simulator(args.firmware, seed, faults=args.faults == "on")
            clock: Clock = simulator.clock
            self.stepped = args.sim_speed
            site = self.site = SimulatedSite(simulator.board, self.plan, self.start,
                                             settings.motion.sensing_range)  # fmt: skip
            for x, y in blocks:
                site.surroundings.block(x, y)
            if moved is not None or hung is not None:
                # The building's markers, not the plan's: the console still goes by these.
                site.world = plan_world(hung or moved or self.plan)
            if args.sim_start is not None:
                room = self.plan.rooms[args.sim_start]
                site.board.place(TruePose(*room.at, math.radians(room.heading or 0.0)))
        else:
            clock = RealClock()
            simulator = None
        control = self.control = control_loop(board_connector(port, settings, simulator),
                                              settings, clock)  # fmt: skip
        if self.site is not None:
            # The simulated robot's casters are the simulator's to say: the thesis's with
            # --imperfect, none on the ideal board (robot/localisation.py).
            control.localisation.casters_turn_up_to(self.site.caster_drift)
        if self.start is not None:
            # The simulator made here puts its robot on the dock, and so the command says
            # where it stands, unless told otherwise (--sim-start). A real robot's console
            # cannot know where it was put down: it assumes the dock, which the markers
            # correct, and without them no mission sets off from it (robot/localisation.py,
            # "No starting guess").
            told = self.site is not None and args.sim_start is None
            control.place(self.start, PoseBasis.GIVEN if told else PoseBasis.ASSUMED)
        if notes is None:
            control.subscribe(_print_note, vital=True)
        else:
            control.subscribe(notes)
        # A real robot: where it was last believed to be, read back as an assumption, and
        # kept from now on (robot/pose_keeper.py).
        self.keeper = None
        if port is not None:
            self.keeper = keep_the_pose(control, self.plan.path.resolve())
        if args.at is not None:
            control.place(placed_at(self.plan, args.at), PoseBasis.GIVEN)
        # The markers find the robot through a camera: the simulator's synthetic one,
        # looked through on the loop's thread, or the robot's own, on a thread of its own
        # as the console's is; without a calibration a real camera cannot place them.
        self.eye: MarkerEye | None = None
        self.camera: CameraFeed | None = None
        if self.plan.landmarks is not None and not args.no_landmarks:
            if self.site is None:
                self.camera = self._robot_camera(args, clock)
            else:
                self.eye = self.site.eye(control.localisation, clock, fps=eye_fps, size=eye_size)
        self.landmarks = self.eye is not None or self.camera is not None
        # What `go` and `patrol` build their missions with: the loop's pose and estimate,
        # its tick, the settings' limits and patience, and the simulator's range finder.
        self.drives = DriveSetup.on_loop(control, self.navigator, limits=self.limits,
                                         sense=self.sense, patience=self.patience)  # fmt: skip
        if self.eye is not None and self.plan.landmarks is not None:
            control.localisation.use_markers(marker_beliefs(self.plan), self.plan.landmarks.size)
            eye = self.eye

            def look(event: LoopEvent) -> None:
                if isinstance(event, Telemetry):
                    eye.look()

            # The simulator is always on a stepped virtual clock: the eye looks on the
            # loop's thread, between ticks (robot/marker_eye.py).
            control.subscribe(look)

    def _robot_camera(self, args: argparse.Namespace, clock: Clock) -> CameraFeed | None:
        """The robot's camera, its markers handed to the localisation; None, with a note,
        if it cannot place them (no calibration)."""
        try:
            feed = camera_feed(args.camera, None, args.calibration,
                               landmarks=self.plan.landmarks, clock=clock)  # fmt: skip
        except (OSError, ValueError) as error:
            raise UsageError(f"--calibration: {error}") from None
        feed.shown = False  # nothing to draw: only the markers are wanted
        feed.pipeline.toggle("fast")  # on for the screen by default
        found = find_the_robot(self.control, feed, self.plan, self.surveying)
        self.control.note(f"camera: {feed.note}" + (f"; {found}" if found else ""))
        if not feed.listeners:  # nothing it could place
            feed.stop()
            return None
        return feed

    def close(self) -> None:
        """Stop what runs beside the loop: the camera, and the pose kept (its last)."""
        if self.camera is not None:
            self.camera.stop()
        if self.keeper is not None:
            self.keeper.close()

    @property
    def sense(self) -> Sense | None:
        """The simulated range finder's readings, for missions; None on a real robot."""
        return self.site.range_finder.readings if self.site is not None else None

    def true_pose(self) -> Pose | None:
        """Where the simulated robot really is (never the console's to know); None on a
        real robot."""
        return self.site.true_pose() if self.site is not None else None

    def run(self, mission: Mission, ended: Callable[[MissionEnd], None],
            meanwhile: Callable[[], None] = lambda: None) -> bool:  # fmt: skip
        """Start the loop, drive `mission` to its end, stop the loop; False if the board
        never answered. `ended` gets the reason, on the loop's thread; `meanwhile` is
        called on this thread every few seconds while it drives, and once after."""
        control = self.control
        connected, done = threading.Event(), threading.Event()

        def finish(end: MissionEnd) -> None:
            try:
                ended(end)
            finally:
                done.set()  # whatever the report did: the command must end

        def start(event: LoopEvent) -> None:
            # On the loop's thread, at the first tick that has the board: the mission
            # starts at the same virtual time however fast the clock runs, before any
            # frame the eye takes meanwhile could make a run differ from the next.
            connected_now = isinstance(event, Telemetry) and event.link is LinkState.CONNECTED
            if connected_now and not connected.is_set():
                connected.set()
                try:
                    control.run_mission(mission, finish)
                except Exception:
                    # The command must not wait on it.
                    finish(MissionEnd(Outcome.HALTED, "stopped: internal error"))
                    raise

        control.subscribe(start)
        # Before the loop's thread starts: SIGHUP (the SSH connection dropped), SIGTERM
        # and SIGINT stop the robot from the loop's own thread and end the mission.
        last_stop = LastStop(control)
        last_stop.install()
        control.start(stepped=self.stepped)
        if self.camera is not None:
            self.camera.start()
        try:
            if not connected.wait(CONNECT_TIMEOUT_S):
                return False
            _show_progress(mission, done, meanwhile)
            return True
        finally:
            control.stop()
            self.close()
            last_stop.uninstall()


def _print_note(event: LoopEvent) -> None:
    """The loop's notes on standard error, where `go` and `patrol` say everything."""
    if isinstance(event, Note):
        # One write for the line and its end: notes come from several threads, and
        # print's two writes would let another's run into this one.
        sys.stderr.write(f"giraff-console: {event.text}\n")
        sys.stderr.flush()


def _show_progress(mission: Mission, done: threading.Event,
                   meanwhile: Callable[[], None]) -> None:  # fmt: skip
    """The mission's progress on standard error until it is `done`: drawn with rich on a
    terminal, else its line every few seconds, as logs and the tests read it; a signal
    ends it (LastStop)."""
    if not sys.stderr.isatty():
        while not done.wait(5.0):
            print(mission.progress.line(), file=sys.stderr)
            meanwhile()
        meanwhile()
        return
    # A row for the mission and one for the part under way (a patrol's stop). Notes
    # printed meanwhile go above the rows; so does standard output if it is the terminal
    # too, but not if it is piped (the JSON lines of --json).
    columns = (
        rich.progress.TextColumn("{task.description}", markup=False),
        rich.progress.BarColumn(bar_width=TEXT_BAR),
        rich.progress.TextColumn("{task.fields[words]}", markup=False),
    )
    bars = rich.progress.Progress(*columns, console=Console(stderr=True), auto_refresh=False,
                                  redirect_stdout=sys.stdout.isatty())  # fmt: skip
    rows: list[rich.progress.TaskID] = []
    shape: list[bool] = []
    with bars:
        while not done.wait(0.5):
            progress = mission.progress
            parts = [part for part in (progress, progress.detail) if part is not None]
            if [part.total_m is not None for part in parts] != shape:
                # A row's bar measures metres or, without them, pulses; rich cannot
                # take a row's total away again, so the rows are made anew.
                for row in rows:
                    bars.remove_task(row)
                rows = [bars.add_task(part.name, total=part.total_m, words="") for part in parts]
                shape = [part.total_m is not None for part in parts]
            for row, part in zip(rows, parts, strict=True):
                bars.update(row, description=part.name, completed=part.done_m or 0.0,
                            total=part.total_m, words=part.words())  # fmt: skip
            bars.refresh()
            meanwhile()
    meanwhile()


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


def _hung_markers(plan: FloorPlan, path: Path | None) -> FloorPlan | None:
    """The plan with the markers of the floor plan at `path` (`--sim-markers`), for the
    simulated building; None without one. FloorPlanError for a plan that cannot be read,
    ValueError for one without markers."""
    if path is None:
        return None
    other = load_floorplan(path)
    if other.landmarks is None or not other.landmarks.markers:
        raise ValueError(f"--sim-markers {path}: the floor plan has no markers to hang")
    return replace(plan, landmarks=other.landmarks)


def placed_at(plan: FloorPlan, text: str) -> Pose:
    """The pose `--at ROOM[:DEG]` says: the room's point (the start room's for `dock`),
    facing DEG or the room's heading. UsageError if there is no such room, or neither
    gives a heading."""
    name, _, degrees = text.partition(":")
    room = plan.rooms.get(plan.start if name == DOCK and plan.start is not None else name)
    if room is None:
        raise UsageError(f"--at: {plan.no_room(name, also=[DOCK] if plan.start else [])}")
    try:
        heading = _finite(float(degrees)) if degrees else room.heading
    except ValueError:
        raise UsageError(f"--at wants ROOM or ROOM:DEGREES, not {text!r}") from None
    if heading is None:
        raise UsageError(f"--at {name}: the room has no heading; say which way the robot "
                         f"faces: --at {name}:DEGREES")  # fmt: skip
    return Pose(room.at[0], room.at[1], math.radians(heading))


def _moved_plan(plan: FloorPlan, moves: list[str]) -> FloorPlan | None:
    """A copy of the plan with markers slid along their walls (`ID:DX`), for the
    simulated building; None without moves. ValueError for a bad move."""
    if not moves:
        return None
    landmarks = plan.landmarks
    if landmarks is None:
        raise ValueError("--move-marker: the floor plan has no markers")
    markers = {marker.id: marker for marker in landmarks.markers}
    walls = marker_walls(plan)
    for text in moves:
        marker_id, along = _move(text)
        if marker_id not in markers:
            raise ValueError(f"--move-marker: the floor plan has no marker {marker_id}")
        marker = markers[marker_id]
        # Along the wall is square to the marker's facing; +90° is the marker's own
        # left, the right of someone standing in front of it.
        angle = math.radians(marker.facing + 90.0)
        at = (marker.at[0] + along * math.cos(angle), marker.at[1] + along * math.sin(angle))
        if fit_on_walls(at, marker.facing, walls).wall is None:
            raise ValueError(f"--move-marker {text}: marker {marker_id} would slide off its "
                             f"wall, to ({at[0]:.2f}, {at[1]:.2f})")  # fmt: skip
        markers[marker_id] = replace(marker, at=at)
    moved = tuple(markers[marker.id] for marker in landmarks.markers)
    return replace(plan, landmarks=replace(landmarks, markers=moved))


def _move(text: str) -> tuple[int, float]:
    try:
        marker_id, along = text.split(":")
        return int(marker_id), _finite(float(along))
    except ValueError:
        raise ValueError(f"--move-marker wants ID:DX (metres), not {text!r}") from None


def _size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise ValueError(f"--eye-size wants WxH in pixels, not {text!r}") from None
    if not (16 <= width <= 4096 and 16 <= height <= 4096):
        raise ValueError(f"--eye-size wants 16 to 4096 pixels a side, not {text!r}")
    return width, height


def _point(text: str) -> tuple[float, float]:
    try:
        x, y = (_finite(float(part)) for part in text.split(","))
    except ValueError:
        raise ValueError(f"--block wants X,Y in metres, not {text!r}") from None
    return x, y


def _finite(value: float) -> float:
    if not math.isfinite(value):
        raise ValueError("not finite")
    return value


def fail(message: str, code: int) -> int:
    """Say what went wrong; the exit code."""
    print(f"giraff-console: {message}", file=sys.stderr)
    return code
