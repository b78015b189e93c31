"""The one composition root (design.md, "The shape"; issue 26): the robot built once.

Every front end gets its robot here: the console in its own process, `go`, `patrol`,
`send`, `survey` and the daemon (`serve`), and the console's test rig, which ticks the
loop itself on the simulator's virtual clock. The screen, `go`, `patrol`, `send` and
the daemon's consoles talk to it through `robot.service` alone; a survey hands its own
mission to its loop (cli/drive.py, run_mission). What the front ends used to build
each for themselves, four times over, is built here
from the settings file and the front end's options (runtime/options.py): the board link
or the simulator in the plan's building, the control loop with its localisation, the
camera and the marker eye, the missions' set-up, the recorder, the route book and the
service on top of them all. One lifetime: `start` runs the loop (and the camera), and
`close` (or leaving the `with`) stops the robot, then everything beside it.

What differs between front ends is said by the options, not by a copy of this:
`screen` draws the camera's pictures and runs the simulator in real time; without it
the simulator runs on a stepped virtual clock and looks for markers on the loop's
thread (missions repeat exactly whatever the speed).
"""

from __future__ import annotations

import math
import signal
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from types import TracebackType

import serial

from giraff_console.camera.feed import CameraFeed
from giraff_console.clock import Clock, RealClock
from giraff_console.data_folders import data_folder, default_recordings, default_routes
from giraff_console.lidar.reader import LidarReader
from giraff_console.lidar.scan import LidarScan, within
from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.missions.lookout import Sense
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.patrol_report import Sight
from giraff_console.missions.sessions import Sessions
from giraff_console.planning.floorplan import FloorPlan, FloorPlanError, Landmarks, load_floorplan
from giraff_console.planning.landmarks import marker_beliefs
from giraff_console.planning.route_planner import walls_of
from giraff_console.recording.session import RecordingSetup
from giraff_console.robot.last_stop import SIGNALS, LastStop
from giraff_console.robot.localisation import PoseBasis
from giraff_console.robot.loop_events import Listener, LoopEvent
from giraff_console.robot.marker_eye import EYE_FPS, EYE_SIZE, MarkerEye
from giraff_console.robot.odometry import Pose
from giraff_console.robot.pose_keeper import PoseKeeper
from giraff_console.robot.telemetry import Telemetry
from giraff_console.runtime.board import (
    board_connector,
    built_in_simulator,
    control_loop,
    keep_the_pose,
    route_book,
    simulator_url,
)
from giraff_console.runtime.camera import camera_feed, find_the_robot
from giraff_console.runtime.lidar import lidar_reader
from giraff_console.runtime.options import (
    RobotOptions,
    UsageError,
    frame_size,
    hung_markers,
    moved_plan,
    placed_at,
    point,
)
from giraff_console.runtime.sim_site import SimulatedSite, plan_world
from giraff_console.service.robot_service import RobotService
from giraff_console.service.virtual_port import VirtualPort
from giraff_console.settings import Settings
from giraff_console.sim.drive import TruePose


class Robot:
    """The robot `options` ask for, on `settings`' rates and limits; UsageError for a
    mistake in the options. Nothing runs until `start`."""

    def __init__(self, options: RobotOptions, settings: Settings, example: Path, *,
                 notes: Listener | None = None) -> None:  # fmt: skip
        """`example`: the floor plan when the options name none.
        `notes`: who hears the loop's notes from the start, where the robot is taken to
        be and what the camera can do included (the daemon's journal, `go`'s standard
        error); vital: if it fails, the robot stops."""
        simulated = options.simulated
        if not simulated:
            given = options.simulator_only()
            if given:
                raise UsageError(f"{', '.join(given)}: only with the simulator (--sim)")
        if not options.sim_speed > 0:  # NaN too
            raise UsageError("--sim-speed must be positive")
        if simulated and options.at is not None:
            raise UsageError("--at: only on a real robot; the simulator's starts on its dock, "
                             "and --sim-start puts it elsewhere")  # fmt: skip
        if options.fast_threshold < 1 or not options.camera_fps > 0:
            raise UsageError("--fast-threshold and --camera-fps must be positive")
        self.options = options
        try:
            plan = self.plan = self._plan(options, example)
            # The simulated building: the plan's own, or another the console is not shown.
            building = load_floorplan(options.sim_building) if options.sim_building else plan
            hung = hung_markers(building, options.sim_markers)
            moved = moved_plan(building, options.move_markers)
            blocks = [point(text) for text in options.blocks]
            eye_fps = EYE_FPS if options.eye_fps is None else options.eye_fps
            eye_size = EYE_SIZE if options.eye_size is None else frame_size(options.eye_size)
            self.navigator = Navigator(plan, walls_of(plan), settings.robot_radius)
        except (FloorPlanError, OSError, ValueError) as error:
            raise UsageError(str(error)) from None
        if not (eye_fps > 0 and math.isfinite(eye_fps)):
            raise UsageError("--eye-fps must be a positive number")
        if options.sim_start is not None and options.sim_start not in building.rooms:
            raise UsageError(f"--sim-start: {building.no_room(options.sim_start)}")
        self.start_pose = start = self.navigator.start_pose
        # Where the simulated robot starts: the building's dock, which the console's plan
        # (one mapped in it, issue 29) has at its own start room.
        docked = start if building is plan else _dock(building)
        # The simulator: in real time for a screen, unless sped up; stepped on a
        # virtual clock without one, so that a run repeats whatever the speed.
        self.site: SimulatedSite | None = None
        self.stepped: float | None = None
        clock: Clock = RealClock()
        simulator: serial.SerialBase | None = None
        if simulated and options.screen:
            simulator = serial.serial_for_url(
                simulator_url(options.firmware, virtual_clock=options.sim_speed != 1)
            )
            if options.sim_speed != 1:
                clock, self.stepped = simulator.clock, options.sim_speed
        elif simulated:
            simulator = built_in_simulator(options.firmware, options.imperfect_seed,
                                           faults=options.faults)  # fmt: skip
            clock, self.stepped = simulator.clock, options.sim_speed
        if simulator is not None:
            site = self.site = SimulatedSite(simulator.board, building, docked,
                                             settings.motion.sensing_range)  # fmt: skip
            for x, y in blocks:
                site.surroundings.block(x, y)
            if moved is not None or hung is not None:
                # The building's markers, not the plan's: the console still goes by these.
                site.world = plan_world(hung or moved or building)
            if options.sim_start is not None:
                room = building.rooms[options.sim_start]
                site.board.place(TruePose(*room.at, math.radians(room.heading or 0.0)))
        control = self.control = control_loop(
            board_connector(options.port, settings, simulator), settings, clock
        )
        if notes is not None:
            control.subscribe(notes, vital=True)
        if self.site is not None:
            # The simulated robot's casters are the simulator's to say: the thesis's with
            # --imperfect, none on the ideal board (robot/localisation.py).
            control.localisation.casters_turn_up_to(self.site.caster_drift)
        if start is not None:
            # The simulator made here puts its robot on the dock, and so the console says
            # where it stands, unless told otherwise (--sim-start). A real robot's console
            # cannot know where it was put down: it assumes the dock, which the markers
            # correct, and without them no mission sets off from it (robot/localisation.py,
            # "No starting guess").
            told = self.site is not None and options.sim_start is None
            control.place(start, PoseBasis.GIVEN if told else PoseBasis.ASSUMED)
        elif self.site is not None:
            # A plan with no start room: the simulated robot stands where it starts.
            control.place(control.pose, PoseBasis.GIVEN)
        # A real robot: where it was last believed to be, read back as an assumption, and
        # kept from now on (robot/pose_keeper.py); unless the operator says (--at).
        self.keeper: PoseKeeper | None = None
        if not simulated:
            self.keeper = keep_the_pose(control, plan.path.resolve())
        if options.at is not None:
            control.place(placed_at(plan, options.at), PoseBasis.GIVEN)
        self.camera: CameraFeed | None = None
        self.eye: MarkerEye | None = None
        self._last_stop: LastStop | None = None
        self._closed = False
        # What the console says of how it was set up, once it has a screen to say it on.
        self.notes_at_start: list[str] = []
        self._see(options, clock, simulator, eye_fps, eye_size)
        recordings = data_folder(options.recordings, settings.recordings, default_recordings())
        setup = RecordingSetup(port=options.port or simulator_url(options.firmware),
                               camera=self._camera_setup())  # fmt: skip
        self.sessions = Sessions(control, self.camera, recordings, setup, control.note)
        # The lidar, if one is asked for (runtime/lidar.py): read on its own thread,
        # its notes the loop's, its revolutions stamped by the loop's clock.
        self.lidar: LidarReader | None = lidar_reader(options, settings.lidar, self.site,
                                                      control.note, clock.now)  # fmt: skip
        # What every mission is built with: the loop's pose and estimate, its tick, the
        # settings' limits and patience, and what senses obstacles: the lidar, as far as
        # the range finder sees (motion.sensing_range), else the simulator's range finder.
        sense: Sense | None = self.site.range_finder.readings if self.site else None
        lidar = self.lidar
        if lidar is not None:
            sensing_range = settings.motion.sensing_range

            def sense_by_lidar() -> LidarScan:
                return within(lidar.readings(), sensing_range)

            sense = sense_by_lidar
        self.drives = DriveSetup.on_loop(
            control, self.navigator, limits=settings.motion.limits(), sense=sense,
            patience=settings.motion.patience(),
        )  # fmt: skip
        routes = data_folder(options.routes, settings.routes, default_routes())
        self.routes = route_book(control, self.sessions, routes, self.drives, settings)
        self.service = RobotService(
            control, self.drives, building=self.site, routes=self.routes,
            sessions=self.sessions, camera=self.camera,
            undock_distance=settings.teleop.undock_distance, sight=self.sight,
            sensor=self.lidar,
        )  # fmt: skip
        # Another program's way to the board, through the service (§4.5).
        self.port: VirtualPort | None = None
        if options.virtual_port:
            try:
                self.port = VirtualPort(self.service, link_timeout=settings.timeout,
                                        drives=settings.port_program_drives)  # fmt: skip
            except OSError as error:
                raise UsageError(f"--virtual-port: no pseudo-terminal: {error}") from None

    @staticmethod
    def _plan(options: RobotOptions, example: Path) -> FloorPlan:
        plan = load_floorplan(options.floorplan or example)
        if options.surveying is not None:
            # A survey's markers are to be found afresh: the plan's family and size, else
            # the survey's; none known yet.
            looked_for = plan.landmarks or options.surveying
            plan = replace(plan, landmarks=replace(looked_for, markers=()))
        return plan

    def _see(self, options: RobotOptions, clock: Clock, simulator: serial.SerialBase | None,
             eye_fps: float, eye_size: tuple[int, int]) -> None:  # fmt: skip
        """The camera, and the markers found through it correcting the pose: a screen's
        camera feed (the simulator's synthetic camera, or the robot's), with the marker
        detector on its own thread; without a screen, the simulated camera looked
        through on the loop's thread between ticks, or the robot's own camera with
        nothing drawn. `shares_camera` (the daemon): a feed its consoles can watch."""
        plan, control = self.plan, self.control
        looks = plan.landmarks is not None and options.landmarks
        if not options.screen and self.site is not None:
            if looks:
                self.eye = self.site.eye(control.localisation, clock, fps=eye_fps, size=eye_size)
            if self.eye is not None and plan.landmarks is not None:
                control.localisation.use_markers(marker_beliefs(plan), plan.landmarks.size)
                eye = self.eye

                def look(event: LoopEvent) -> None:
                    if isinstance(event, Telemetry):
                        eye.look()

                # The simulator is on a stepped virtual clock: the eye looks on the loop's
                # thread, between ticks (robot/marker_eye.py).
                control.subscribe(look)
            if options.shares_camera:
                # What the consoles watch: the same building through the synthetic camera,
                # its markers outlined; the eye, not this, finds the robot by them.
                self.camera = self._feed(options, clock, simulator, plan.landmarks)
                self.camera.shown = False
            return
        # A real robot's camera is opened for the consoles elsewhere only if it is named
        # (--camera) or opened for the markers anyway: camera 0 may be the video call's.
        shares = options.shares_camera and (looks or options.camera is not None)
        if not (options.screen or looks or shares):
            return
        feed = self._feed(options, clock, simulator, plan.landmarks if looks else None)
        found = find_the_robot(control, feed, plan, options.surveying is not None)
        if options.screen:
            self.camera = feed
            if found is not None:
                self.notes_at_start.append(found)
            return
        feed.shown = False  # nothing drawn here: the markers, and the consoles elsewhere
        if not shares:
            feed.pipeline.toggle("fast")  # on for a screen by default
        control.note(f"camera: {feed.note}" + (f"; {found}" if found else ""))
        if not (feed.listeners or shares):  # nothing it could place, nobody to show
            feed.stop()
            return
        self.camera = feed

    def _feed(self, options: RobotOptions, clock: Clock, simulator: serial.SerialBase | None,
              landmarks: Landmarks | None) -> CameraFeed:  # fmt: skip
        """The camera asked for (the simulator's in the simulated building), its marker
        detector looking for `landmarks`."""
        site = self.site
        try:
            return camera_feed(
                options.camera, simulator, options.calibration, options.fast_threshold,
                options.camera_fps, site.world if site else None,
                site.surroundings if site else None, landmarks, clock,
            )  # fmt: skip
        except (OSError, ValueError) as error:
            raise UsageError(f"--calibration: {error}") from None

    def _camera_setup(self) -> dict[str, object]:
        """The camera as a recording's metadata says it was set up."""
        camera, options = self.camera, self.options
        if camera is None:
            return {}
        return {"source": camera.source.name, "size": list(camera.size),
                "fps_cap": options.camera_fps, "fast_threshold": options.fast_threshold,
                "calibration": options.calibration}  # fmt: skip

    @property
    def landmarks(self) -> bool:
        """Whether markers find the robot: through the eye or the camera."""
        return self.eye is not None or (self.camera is not None and bool(self.camera.listeners))

    def sight(self) -> Sight:
        """What finds the robot, and what the eye has cost: for a patrol's report."""
        return Sight(self.landmarks, self.eye.cost() if self.eye is not None else None)

    def true_pose(self) -> Pose | None:
        """Where the simulated robot really is (never the console's to know); None on a
        real robot."""
        return self.site.true_pose() if self.site is not None else None

    # -- lifetime -----------------------------------------------------------------------

    def guard(self, leave: Callable[[str], None] = lambda why: None,
              signals: frozenset[signal.Signals] = SIGNALS) -> LastStop:  # fmt: skip
        """Before `start`: every way the process can end (`signals`, a crash) stops the
        robot from the loop's own thread, then asks the front end to `leave`
        (robot/last_stop.py). Installed until `close`."""
        self._last_stop = LastStop(self.control, leave=leave, signals=signals)
        self._last_stop.install()
        return self._last_stop

    def start(self) -> None:
        """Run the control loop, and the lidar, the camera and the virtual port beside
        it."""
        self.control.start(stepped=self.stepped)
        if self.lidar is not None:
            self.lidar.start()
        if self.camera is not None:
            self.camera.start()
        if self.port is not None:
            self.port.start()

    def stop(self) -> bool:
        """Stop the robot and end the loop, at once (a console leaving stops it first,
        before its screen takes its time to close); True once it was commanded to stop
        and the port closed (ControlLoop.stop)."""
        return self.control.stop()

    def close(self) -> None:
        """Stop the robot and the loop, then what runs beside it: the service's
        workers, the camera, and the pose kept (its last); the signal guard last of all.
        Once; again does nothing. Each part is closed whatever the one before did."""
        if self._closed:
            return
        self._closed = True
        try:
            if self.port is not None:
                self.port.close()  # the program sees the port go, then the robot stops
            self.stop()
        finally:
            try:
                self.service.close()
                if self.camera is not None:
                    self.camera.stop()
                if self.lidar is not None:
                    self.lidar.close()
            finally:
                if self.keeper is not None:
                    self.keeper.close()
                if self._last_stop is not None:
                    self._last_stop.uninstall()

    def __enter__(self) -> Robot:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:  # fmt: skip
        self.close()


def _dock(building: FloorPlan) -> Pose | None:
    """Where `building` says the robot starts: its start room's point and heading."""
    if building.start is None:
        return None
    room = building.rooms[building.start]
    return Pose(room.at[0], room.at[1], math.radians(room.heading or 0.0))
