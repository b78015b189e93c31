"""The robot as one service: requests in, one stream of events out (issue 15).

Whoever runs the control loop (the console on its own, or the daemon `serve`) puts the
robot's parts together once and wraps them in a RobotService; the front ends then only
`execute` requests (service/commands.py) and listen. Every request is answered with a
Reply for whoever asked; what everyone should see (notes, telemetry, missions starting
and ending, who holds the controls, the route on the map) goes out as events.

Who may drive (issue 15, item 3): several consoles may be attached, and one holds the
controls; a request that can move the robot from another is refused, but anyone may
stop it. A console that hangs up while holding the controls lets go of the keys at once
(the deadman would within its repeat timeout anyway); a mission it started carries on.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any, Protocol, TypeAlias

import numpy as np

from giraff_console.camera.feed import CameraFeed
from giraff_console.camera.shared_frame import SharedFrame, SharedFrameError, share
from giraff_console.link import BoardLink
from giraff_console.missions.certainty import unverified
from giraff_console.missions.docking import DOCK
from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.missions.navigation import NavigationState
from giraff_console.missions.patrol_report import PatrolReports, Sight
from giraff_console.missions.route_book import RouteBook
from giraff_console.missions.scan_fixing import ScanFixer
from giraff_console.missions.sessions import Sessions
from giraff_console.planning.floorplan import is_id
from giraff_console.planning.grid import OccupancyGrid
from giraff_console.planning.room_graph import PlanningError
from giraff_console.planning.room_names import RenameError, rename_in_file
from giraff_console.protocol import CommandError, GiraffError, parse_command
from giraff_console.recording.playback import Playback
from giraff_console.robot.command_guard import check_command
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.localisation import PoseBasis
from giraff_console.robot.loop_events import LoopEvent, MissionChanged
from giraff_console.robot.mission import MissionEnd, Outcome
from giraff_console.robot.odometry import Pose
from giraff_console.robot.safety import stop_robot
from giraff_console.robot.stalk import head_height, stepped
from giraff_console.robot.telemetry import Telemetry
from giraff_console.service import commands as c
from giraff_console.service.building_map import BuildingMap, ScanSource
from giraff_console.service.command_batch import CommandBatch
from giraff_console.service.events import (
    Answered,
    Controls,
    GoReported,
    MapDrawn,
    PatrolReported,
    PatrolStopReported,
    PlanChanged,
    Reply,
    RoomRenamed,
    RouteShown,
    SendEnd,
    Sent,
    ServiceListener,
    Situation,
)
from giraff_console.service.status import status_lines

# The console that runs the robot in its own process: it holds the controls alone.
HERE = "this console"
# Seconds after an operator last moved the robot during which a scheduled patrol waits.
IN_USE_S = 300.0
# What starts a mission, which a stop while it is being planned must cancel.
STARTS_MISSION = (c.Go, c.RunPatrol, c.Follow, c.Replay, c.Undock)


def _moves(request: c.Request) -> bool:
    """Whether `request` may move the robot: a controller command that only reads does
    not, so that a watcher may ask for bulk_data."""
    if isinstance(request, c.Send):
        return not _reads(request.text)
    if isinstance(request, c.SendCommands):
        return not all(map(_reads, request.texts))
    return request.moves


def _reads(text: str) -> bool:
    """Whether a controller command as typed only reads (one that does not parse may
    move, for all that is known, and is refused when it is looked at)."""
    try:
        return parse_command(text).kind == "get"
    except CommandError:
        return False


def _finite(request: c.Request) -> bool:
    """No NaN or infinity in a request's numbers (one from another process could)."""
    return all(math.isfinite(value) for value in vars(request).values()
               if isinstance(value, float))  # fmt: skip


class Building(Protocol):
    """The simulated building: its doors and the boxes put in the robot's way."""

    def close_door(self, door_id: str) -> None: ...
    def open_door(self, door_id: str) -> None: ...
    def block(self, x: float, y: float) -> str: ...
    def unblock(self, x: float, y: float) -> list[str]: ...
    def true_pose(self) -> Pose:
        """Where the robot really is: for reports and tests, never for driving."""


class RobotService:
    """The robot's parts behind one surface; all methods are safe from any thread."""

    def __init__(self, control: ControlLoop, drives: DriveSetup, *,
                 building: Building | None = None, routes: RouteBook | None = None,
                 sessions: Sessions | None = None, camera: CameraFeed | None = None,
                 undock_distance: float = 0.3,
                 sight: Callable[[], Sight] | None = None,
                 sensor: ScanSource | None = None) -> None:  # fmt: skip
        self.control = control
        self.drives = drives
        self.navigator = drives.navigator
        self.building = building
        self.routes = routes
        self.sessions = sessions
        self.undock_distance = undock_distance
        # What finds the robot, for a patrol's report (runtime/robot.py knows its eye);
        # without it, what the localisation says.
        self.sight = sight or (lambda: Sight(landmarks=control.estimate().landmarks))
        # What the services say goes out to every listener, as the loop's own notes do.
        for part in (routes, sessions):
            if part is not None:
                part.report = control.note
        self._lock = threading.Lock()
        # Held while a mission is planned and handed to the loop, and while a room is
        # renamed: a mission planned by the old names must not start on the new plan.
        self._plan_lock = threading.Lock()
        self._consoles: list[str] = []
        self._holder: str | None = None
        # Clients whose mission ends when another takes the controls (the fleet: an
        # operator who takes them means to drive, issue 28), and who started the latest
        # mission.
        self._yielding: set[str] = set()
        self._mission_by: str | None = None
        self._listeners: tuple[ServiceListener, ...] = ()
        # Each listener as the loop knows it: with the recording filled in.
        self._on_loop: dict[ServiceListener, Callable[[LoopEvent], None]] = {}
        self.telemetry: Telemetry | None = None
        # Every stop counts: a mission planned meanwhile does not start (execute).
        self._stops = 0
        # A braking stop (Halt) on its way to the board, not yet sent.
        self._braking = False
        # Called at each operator's stop: what else may move the robot is held; and at
        # `release`, when the operator lets it go again.
        self.on_stop: list[Callable[[], None]] = []
        self.on_release: list[Callable[[], None]] = []
        # When the controls' holder last moved the robot (time.monotonic): the schedule
        # does not take the robot from an operator who is using it.
        self._moved_at = -math.inf
        self._route_shown: NavigationState | None = None
        # The mission under way and the last one to end, as the loop told them: changed
        # together, so that `status` never sees one gone and its end not yet known.
        self._missions: tuple[str | None, MissionChanged | None] = (None, None)
        # The camera, and the consoles elsewhere that show it (c.View): it shares its
        # frames while any does, each encoded once for them all (camera/shared_frame.py).
        self.camera = camera
        self._viewers: set[str] = set()
        self._shared: tuple[np.ndarray, SharedFrame] | None = None
        # The building mapped as it is driven (issue 29), with the range sensor's turns.
        self.building_map = BuildingMap(control, self.navigator, sensor, self._tell)
        # Its revolutions fitted to the plan's map correct the pose (missions/
        # scan_fixing.py).
        self.scan_fixes: ScanFixer | None = None
        if sensor is not None and self.navigator is not None:
            self.scan_fixes = ScanFixer(self._walls_to_fit, control.localisation.scan_fitted,
                                        control.note)  # fmt: skip
            sensor.subscribe(self.scan_fixes.scan)
        control.subscribe(self._heard)

    def post(self, request: c.Request, answered: Answered = lambda reply: None) -> None:
        """Ask for this console, on this thread: a front end runs the requests that are
        not `quick` (planning a route takes a few hundred milliseconds) off its own."""
        answered(self.execute(request))

    def close(self) -> None:
        """The front end is closing: a recording it left running is closed whole."""
        if self.sessions is not None:
            self.sessions.stop_recording()
        self.building_map.close()
        sensor = self.building_map.sensor
        if self.scan_fixes is not None and sensor is not None:
            sensor.unsubscribe(self.scan_fixes.scan)
            self.scan_fixes.close()

    # -- listening ----------------------------------------------------------------------

    def subscribe(self, listener: ServiceListener, *, vital: bool = False) -> None:
        """Hear everything: the loop's events (a vital listener that fails stops the
        robot, ControlLoop.subscribe) and the service's own."""
        sessions = self.sessions

        def on_loop(event: LoopEvent) -> None:
            if isinstance(event, Telemetry) and sessions is not None and sessions.recording:
                event = replace(event, recording=True)
            listener(event)

        with self._lock:
            self._listeners += (listener,)
            self._on_loop[listener] = on_loop
        self.control.subscribe(on_loop, vital=vital)

    def unsubscribe(self, listener: ServiceListener) -> None:
        with self._lock:
            self._listeners = tuple(other for other in self._listeners if other != listener)
            on_loop = self._on_loop.pop(listener, None)
        if on_loop is not None:
            self.control.unsubscribe(on_loop)

    def _tell(self, event: Controls | RouteShown | RoomRenamed | GoReported | PatrolStopReported
              | PatrolReported | SharedFrame | MapDrawn | PlanChanged) -> None:  # fmt: skip
        for listener in self._listeners:
            listener(event)

    def _heard(self, event: LoopEvent) -> None:
        if isinstance(event, Telemetry):
            self.telemetry = event
            if self.scan_fixes is not None and event.playback is None:
                # A playback's poses are the recording's, not where the robot is.
                sigma = event.estimate.sigma_heading if event.estimate is not None else 0.0
                self.scan_fixes.pose(self.control.clock.now(), event.pose, sigma)
            navigator = self.navigator
            # Patrols' legs, replans and obstacles change the route without a request.
            if navigator is not None and navigator.state is not self._route_shown:
                self._route_shown = navigator.state
                self._tell(RouteShown.of(navigator.state))
        elif isinstance(event, MissionChanged):
            last = self._missions[1]
            self._missions = (event.name, last) if event.running else (None, event)

    def _walls_to_fit(self) -> OccupancyGrid | None:
        """The plan's walls, for the scans to be fitted to; none while a map is being
        made (the plan it will be is not drawn yet), nor during a survey (its graph
        knows the wheels and the markers only: a pose the scans moved would not be the
        one it solves)."""
        if (self.building_map.mapping or self.navigator is None
                or self.control.localisation.survey is not None):  # fmt: skip
            return None
        return self.navigator.walls

    # -- consoles and the controls ------------------------------------------------------

    def attach(self, console: str, *, take: bool = True, yields: bool = False) -> None:
        """A console comes; it holds the controls if nobody does and `take`. `yields`: a
        mission it started ends as soon as another console takes the controls."""
        with self._lock:
            self._consoles.append(console)
            if yields:
                self._yielding.add(console)
            if take and self._holder is None:
                self._holder = console
        self._tell(self.controls())

    def detach(self, console: str) -> None:
        """A console goes (hung up, or its connection died): if it held the controls,
        the keys it held are let go of now, and nobody holds them until one takes them.
        A mission it started carries on."""
        self._view(console, on=False)
        with self._lock:
            if console in self._consoles:
                self._consoles.remove(console)
            held = self._holder == console
            if held:
                self._holder = None
        if held:
            self.control.halt()
            self.control.note(f"{console} left; its keys let go; the controls are free")
        self._tell(self.controls())

    def let_go(self, console: str) -> None:
        """`console` no longer drives (a program on the virtual port that stopped its
        move): if it held the controls, nobody holds them until one takes them."""
        with self._lock:
            held = self._holder == console
            if held:
                self._holder = None
        if held:
            self._tell(self.controls())

    def controls(self) -> Controls:
        with self._lock:
            return Controls(self._holder, tuple(self._consoles))

    def may_move(self, console: str) -> str | None:
        """Why `console` may not move the robot now, or None. Nobody holding the controls
        (a console left, or a command from the shell) lets the first to move take them."""
        with self._lock:
            if console != HERE and console not in self._consoles:
                return "refused: not attached (hung up)"
            self._moved_at = time.monotonic()
            if self._holder is None:
                self._holder = console
            elif self._holder != console:
                return (f"refused: {self._holder} holds the controls (a console's Ctrl+T or "
                        "`take` asks for them)")  # fmt: skip
            else:
                return None
        self._tell(self.controls())
        return None

    def in_use(self) -> str | None:
        """Why the robot is busy for a scheduled patrol, or None: a mission, keys held, or
        an operator who moved it in the last IN_USE_S seconds."""
        mission = self.control.mission
        if mission is not None:
            return f"{mission.name} is running"
        if self.control.deadman.held() is not None:
            return "the robot is being driven by the keys"
        if time.monotonic() - self._moved_at < IN_USE_S:
            return f"an operator used the robot in the last {IN_USE_S / 60:.0f} minutes"
        return None

    # -- requests -----------------------------------------------------------------------

    def execute(self, request: c.Request, console: str = HERE) -> Reply:
        """Do what `request` asks, for `console`; the reply says whether it was done."""
        if not _finite(request):
            return Reply(False, "refused: a number that is not a number")
        if _moves(request):
            refused = self.may_move(console)
            if refused is not None:
                return Reply(False, refused)
        handler = HANDLERS[type(request)]
        stops = self._stops
        plans = isinstance(request, (*STARTS_MISSION, c.Name, c.Mark, c.SaveMap))
        with self._plan_lock if plans else contextlib.nullcontext():
            reply = handler(self, request, console)
        if isinstance(request, STARTS_MISSION) and reply.ok and self._stops != stops:
            # A stop came while the mission was being planned, before the loop had it: the
            # stop must win. Queued after the start, so the mission ends before its first
            # tick; a later stop queues after it anyway.
            self.control.stop_mission(Outcome.CANCELLED, "stopped before it started")
            return Reply(False, "stopped before it started")
        if isinstance(request, STARTS_MISSION) and reply.ok:
            self._mission_by = console
        return reply

    def started_by(self) -> str | None:
        """Who started the mission under way (or about to start), or None without one."""
        running = self.control.mission is not None or self.control.missions_starting
        return self._mission_by if running else None

    def _do_press(self, request: c.Press) -> Reply:
        if self.control.playback is not None:
            return Reply(False, "playing back: the driving keys are off; p returns to live")
        self.control.press(request.intent)
        return Reply(True)

    def _do_halt(self, request: c.Halt) -> Reply:
        """Let go of the keys, and stop any move, typed or undocking, as well, and hold
        whatever else may move the robot (a program on the virtual port) until the
        operator lets it go again."""
        self._stopped()
        self.control.halt()
        self.control.stop_mission()
        # One braking stop on its way to the board stops for every Halt asked meanwhile:
        # a console asking again and again (a flood, issue 30) must not fill the loop's
        # ticks with board exchanges. A mission started meanwhile is ended by the
        # stop_mission above, which stops the robot again.
        with self._lock:
            braking, self._braking = self._braking, True
        if not braking:
            self.control.submit(stop_robot, self._braked, stop=True)
        return Reply(True, "stop")

    def _braked(self, result: object) -> None:
        """The braking stop was sent, or could not be (the loop's thread)."""
        with self._lock:
            self._braking = False

    def _stopped(self) -> None:
        self._stops += 1
        for hold in self.on_stop:
            hold()

    def _do_speed(self, request: c.Speed) -> Reply:
        teleop = self.control.teleop
        wanted = request.to if request.to is not None else teleop.speed + 0.05 * request.step
        return Reply(True, f"driving speed {teleop.set_speed(round(wanted, 2)):.2f} m/s")

    def _do_poll(self, request: c.Poll) -> Reply:
        control = self.control
        control.autopoll = not control.autopoll if request.on is None else request.on
        return Reply(True, f"automatic odometry poll {'on' if control.autopoll else 'off'}")

    def _do_send(self, request: c.Send) -> Reply:
        try:
            command = parse_command(request.text)
        except CommandError as error:
            return Reply(False, f"refused: {error}")
        if self.control.playback is not None:
            return Reply(False, "not sent: playing back, nothing goes to the robot "
                                "(p returns to live)")  # fmt: skip
        teleop = self.control.teleop
        note = self.control.note

        def job(link: BoardLink) -> object:
            # On the loop's thread, where the board's settings are known for sure:
            # nothing can change them between the check and the command.
            check_command(command, teleop.limits, teleop.board_settings)
            return link.send(command)

        def done(outcome: object) -> None:
            # Told to every console, as the exchange itself is shown to every one: the
            # request is answered as soon as it is queued, so that a key never waits
            # for the loop.
            if isinstance(outcome, CommandError):
                note(f"refused: {outcome}")
            elif isinstance(outcome, GiraffError):
                note(str(outcome))

        self.control.submit(job, done)
        return Reply(True)

    def _do_sendcommands(self, request: c.SendCommands) -> Reply:
        """Check them all, send them in order and answer with the board's answers, on
        the loop's thread (service/command_batch.py); this waits for them."""

        def refused(why: str) -> Reply:
            return Reply(False, why, sent=Sent(SendEnd.REFUSED, why=why))

        if not 1 <= len(request.texts) <= c.MAX_COMMANDS:
            return refused(f"refused: from 1 to {c.MAX_COMMANDS} commands at once, not "
                           f"{len(request.texts)}")  # fmt: skip
        try:
            commands = [parse_command(text) for text in request.texts]
        except CommandError as error:
            return refused(f"refused: {error}")
        if self.control.playback is not None:
            return refused("not sent: playing back, nothing goes to the robot (p returns to live)")
        stops, control = self._stops, self.control
        # An operator's stop since they were asked, or the loop's own, wins over them.
        batch = CommandBatch(commands, control,
                             stopped=lambda: self._stops != stops or control.stopping)  # fmt: skip
        sent = batch.send()
        return Reply(sent.end is SendEnd.ANSWERED, sent.why, sent=sent)

    def _do_stalk(self, request: c.Stalk) -> Reply:
        telemetry = self.telemetry
        board = telemetry.board if telemetry is not None else None
        if board is not None and not board.stalk:
            # A board not yet probed is asked anyway: it answers `Unknown name: h`.
            return Reply(False, "this board has no height stalk (its firmware does not know h)")
        target = request.to
        if target is None:
            height = telemetry.stalk if telemetry is not None else None
            if height is None:
                return Reply(False, "the stalk's height is not known yet: stalk N sets it")
            target = stepped(height, request.step)
            if target == height:
                return Reply(False, f"the stalk is already at its "
                                    f"{'top' if request.step > 0 else 'bottom'}")  # fmt: skip
        sent = self._do_send(c.Send(f"set h {target}"))
        if not sent.ok:
            return sent
        return Reply(True, f"stalk to {target} (head at {head_height(target):.2f} m)")

    # -- missions -----------------------------------------------------------------------

    def _do_go(self, request: c.Go) -> Reply:
        """Plan (a few hundred milliseconds on a large plan) and let the loop drive."""
        navigator = self.navigator
        if navigator is None:
            return Reply(False, "go: no floor plan (start the console with --floorplan FILE)")
        if self.control.playback is not None:
            return Reply(False, "go: playing back; p returns to live first",
                         refused=Outcome.NOT_STARTED)  # fmt: skip
        # Refused here, not by the mission's first tick after a reply that says it goes.
        refusal = unverified(self.control.estimate(), f"go {request.room}")
        if refusal is not None:
            return Reply(False, f"go: {refusal}", refused=Outcome.UNVERIFIED)
        try:
            mission = self.drives.go(request.room)
        except (PlanningError, ValueError) as error:  # ValueError: a pose off the map
            return Reply(False, f"go: {error}", refused=Outcome.BLOCKED)
        planned = navigator.state.planned
        text = f"going to {request.room}"
        if planned is not None:
            through = ", ".join(planned.route.doors) or "no door"
            text = (f"route to {request.room}: {planned.length_m:.1f} m through {through}; "
                    f"{mission.time_optimal:.0f} s at best; Space stops, pause and resume "
                    "hold it")  # fmt: skip
        self._tell(RouteShown.of(navigator.state))

        def ended(end: MissionEnd) -> None:
            if end.outcome.arrived:
                navigator.forget()
            self._tell(RouteShown.of(navigator.state))
            truth = self.building.true_pose() if self.building is not None else None
            self._tell(GoReported(mission.report(end, truth)))

        self.control.run_mission(mission, ended)
        return Reply(True, text)

    def _book(self, act: Callable[[RouteBook], object]) -> Reply:
        """A request the route book answers (it says what happened, or why not, in a
        note to every console)."""
        if self.routes is None:
            return Reply(False, "routes are not available")
        try:
            done = act(self.routes) is not False
        except ValueError as error:  # a pose off the map, planning a patrol's first leg
            return Reply(False, str(error))
        return Reply(done, "" if done else "not done: the note above says why")

    def _do_runpatrol(self, request: c.RunPatrol, console: str) -> Reply:
        return self._book(lambda book: book.patrol(request.name, by=console,
                                                   reports=self._patrol_reports()))  # fmt: skip

    def _patrol_reports(self) -> PatrolReports:
        """A patrol's reports, each stop's and the run's, told to every listener: the
        patrol command prints them, in this process or another (issue 26)."""
        building = self.building
        return PatrolReports(
            stop=lambda report: self._tell(PatrolStopReported(report)),
            end=lambda report: self._tell(PatrolReported(report)),
            true_pose=building.true_pose if building is not None else lambda: None,
            sight=self.sight,
        )  # fmt: skip

    def run_scheduled(self, patrol: str) -> Reply:
        """Start a scheduled patrol, unless the robot is in use (`in_use`). The controls'
        holder does not matter: the patrol is the daemon's own, and an operator who only
        watches must not keep it from the night."""
        busy = self.in_use()
        if busy is not None:
            return Reply(False, busy)
        if self.routes is None:
            return Reply(False, "routes are not available")
        with self._plan_lock:
            started = self.routes.patrol(patrol, by="schedule", scheduled=True,
                                         reports=self._patrol_reports())  # fmt: skip
        if started:
            self._mission_by = "schedule"
        return Reply(started)

    def _do_follow(self, request: c.Follow) -> Reply:
        return self._book(lambda book: book.follow(request.name))

    def _do_replay(self, request: c.Replay) -> Reply:
        return self._book(lambda book: book.replay(request.name))

    def _do_undock(self, request: c.Undock) -> Reply:
        if self.control.playback is not None:
            return Reply(False, "not sent: playing back, nothing goes to the robot")
        reply = self._book(lambda book: book.undock(self.undock_distance))
        if not reply.ok:
            return reply
        return Reply(True, f"undocking: backing out {self.undock_distance:g} m; Space stops")

    def _do_teach(self, request: c.Teach) -> Reply:
        return self._book(lambda book: book.teach(request.name))

    def _do_mark(self, request: c.Mark) -> Reply:
        """On the route being taught, a place on it; else the room the robot is in gets
        the name (§2.6.3: "the robot would be told the name of the room the robot is in")."""
        if self.routes is not None and self.routes.teacher is not None:
            return self._book(lambda book: book.mark(request.place))
        if self.building_map.mapping:
            if not is_id(request.place):
                return Reply(False, f"mark: {request.place!r} cannot name a room: letters, "
                                    "digits, - and _ only")  # fmt: skip
            return self.building_map.mark(request.place)
        if self.navigator is None:
            return Reply(False, "mark: not teaching a route (`teach NAME` first), and no "
                                "floor plan to name a room of")  # fmt: skip
        pose = self.control.pose
        room = self.navigator.planner.room_at((pose.x, pose.y))
        reply = self._rename(room, request.place, where=" (where the robot stands)")
        if not reply.ok:
            return reply
        return replace(reply, text=f"{reply.text}; `name {request.place} {room}` undoes it")

    def _do_place(self, request: c.Place) -> Reply:
        """Where the robot stands, as the operator says (robot/localisation.py, "No
        starting guess"): a room's point, facing its heading or the one given."""
        navigator = self.navigator
        if navigator is None:
            return Reply(False, "place: no floor plan (start the console with --floorplan FILE)")
        if self.control.mission is not None or self.control.missions_starting:
            return Reply(False, "place: not while a mission runs; stop it first")
        plan = navigator.plan
        name = plan.start if request.room == DOCK and plan.start is not None else request.room
        room = plan.rooms.get(name)
        if room is None:
            docks = [DOCK] if plan.start is not None else []
            return Reply(False, f"place: {plan.no_room(request.room, also=docks)}")
        degrees = request.heading if request.heading is not None else room.heading
        if degrees is None:
            return Reply(False, f"place: {request.room} has no heading in the plan: say which "
                                f"way the robot faces (place {request.room} DEGREES, "
                                "counter-clockwise from the map's x axis)")  # fmt: skip
        pose = Pose(room.at[0], room.at[1], math.radians(degrees))
        self.control.between_ticks(lambda: self.control.place(pose, PoseBasis.GIVEN))
        return Reply(True, f"placed at {request.room} ({pose.x:.2f}, {pose.y:.2f}), facing "
                           f"{degrees % 360:.0f}°, as the operator says")  # fmt: skip

    def _do_name(self, request: c.Name) -> Reply:
        return self._rename(request.room, request.to)

    def _rename(self, room: str, to: str, where: str = "") -> Reply:
        """Room `room` renamed `to` in the plan's file, and for everyone from now on."""
        navigator = self.navigator
        if navigator is None:
            return Reply(False, "name: no floor plan (start the console with --floorplan FILE)")
        mission = self.control.mission
        if mission is not None or self.control.missions_starting:
            running = f"{mission.name} runs" if mission is not None else "a mission starts"
            return Reply(False, f"name: not while {running}: it goes by the old names")
        try:
            plan = rename_in_file(navigator.plan, room, to)
        except RenameError as error:
            return Reply(False, f"name: {error}")
        except OSError as error:
            return Reply(False, f"name: {navigator.plan.path} not saved, nothing renamed: "
                                f"{error.strerror or error}")  # fmt: skip
        navigator.use_plan(plan)
        self._tell(RoomRenamed(room, to))
        self._tell(RouteShown.of(navigator.state))
        text = f"room {room}{where} is now {to}; saved in {plan.path}"
        going = self.routes.patrols_going_to(room) if self.routes is not None else []
        if going:
            text += (f"; patrols {', '.join(going)} still stop at {room}: change them to {to} "
                     f"in their files")  # fmt: skip
        return Reply(True, text)

    def _do_startmapping(self, request: c.StartMapping) -> Reply:
        return self.building_map.start()

    def _do_savemap(self, request: c.SaveMap) -> Reply:
        return self.building_map.save(request.to)

    def _do_discardmap(self, request: c.DiscardMap) -> Reply:
        return self.building_map.discard()

    def _do_done(self, request: c.Done) -> Reply:
        return self._book(lambda book: book.done() is not None)

    def _do_routes(self, request: c.Routes) -> Reply:
        if self.routes is None:
            return Reply(False, "routes are not available")
        return Reply(True, lines=tuple(self.routes.listing()))

    def _do_pause(self, request: c.Pause) -> Reply:
        return self._hold(paused=True)

    def _do_resume(self, request: c.Resume) -> Reply:
        return self._hold(paused=False)

    def _hold(self, paused: bool) -> Reply:
        """Pause or resume the playback, else the mission."""
        playback = self.control.playback
        if playback is not None:
            now = self.control.clock.now()
            (playback.pause if paused else playback.resume)(now)
            return Reply(True, f"playback {'paused' if paused else 'resumed'}")
        if self.control.mission is None:
            return Reply(False, f"nothing to {'pause' if paused else 'resume'}")
        self.control.pause_mission(paused)  # the loop says it did
        return Reply(True)

    def _do_stopmission(self, request: c.StopMission, console: str) -> Reply:
        """End the mission, or the one about to start (the loop may not have it yet); a
        client's own cancel (not `operator`) ends only a mission it started."""
        if request.operator:
            self._stopped()
            self.control.stop_mission()
        elif self.started_by() == console:
            self.control.stop_mission(Outcome.CANCELLED, f"cancelled by {console}")
        else:
            return Reply(False, "no mission of yours to stop")
        return Reply(True)

    # -- the building -------------------------------------------------------------------

    def _do_door(self, request: c.Door) -> Reply:
        navigator = self.navigator
        word = "open" if request.open else "close"
        if navigator is None:
            return Reply(False, f"{word}: no floor plan (start the console with --floorplan FILE)")
        if request.door not in navigator.door_ids():
            return Reply(False, f"{word}: no door {request.door!r}; doors: "
                                f"{', '.join(navigator.door_ids())}")  # fmt: skip
        if self.building is not None:
            # The simulated building's door too: the range finder will see it.
            (self.building.open_door if request.open else self.building.close_door)(request.door)
        change = navigator.open if request.open else navigator.close
        try:
            state = change(request.door, self.control.pose)
        except PlanningError as error:
            return Reply(False, f"{word}: {error}")
        self._tell(RouteShown.of(navigator.state))
        text = f"door {request.door} {'open' if request.open else 'closed'}"
        if state.goal is not None and state.planned is None:
            text += f"; {state.problem}"
        elif state.goal is not None and state.planned is not None:
            text += f"; route to {state.goal} now {state.planned.length_m:.1f} m"
        return Reply(True, text)

    def _do_block(self, request: c.Block) -> Reply:
        word = "block" if request.on else "unblock"
        if self.building is None:
            return Reply(False, f"{word}: only in the simulator (there is no building to change)")
        x, y = request.x, request.y
        if request.on:
            return Reply(True, f"{self.building.block(x, y)} put at ({x:g}, {y:g})")
        removed = self.building.unblock(x, y)
        return Reply(
            True, f"removed {', '.join(removed)}" if removed else f"nothing at ({x:g}, {y:g})"
        )

    # -- sessions -----------------------------------------------------------------------

    def _do_record(self, request: c.Record) -> Reply:
        sessions = self.sessions
        if sessions is None:
            return Reply(False, "recording is not available")
        if not request.on:
            return Reply(sessions.stop_recording() is not None)
        if sessions.recording:
            return Reply(False, "already recording")
        return Reply(sessions.start_recording() is not None)

    def _do_play(self, request: c.Play) -> Reply:
        sessions = self.sessions
        if sessions is None:
            return Reply(False, "playback is not available")
        if request.stop:
            sessions.stop_playback()
            return Reply(True)
        return Reply(sessions.start_playback(request.session) is not None)

    def _playback(self) -> Playback | None:
        return self.control.playback

    def _do_seek(self, request: c.Seek) -> Reply:
        playback = self._playback()
        if playback is None:
            return Reply(False, "no playback running: p plays the newest session")
        now = self.control.clock.now()
        to = request.to if request.to is not None else playback.position(now) + request.by
        self.control.seek(to)
        return Reply(True)

    def _do_rate(self, request: c.Rate) -> Reply:
        playback = self._playback()
        if playback is None:
            return Reply(False, "no playback running: p plays the newest session")
        wanted = request.to if request.to is not None else playback.speed * request.times
        return Reply(True, f"playback at {playback.set_speed(self.control.clock.now(), wanted):g}x")

    def _do_step(self, request: c.Step) -> Reply:
        playback = self._playback()
        if playback is None:
            return Reply(False, "no playback running: p plays the newest session")
        playback.step(self.control.clock.now())
        return Reply(True)

    # -- who drives ---------------------------------------------------------------------

    def _do_takecontrols(self, request: c.TakeControls, console: str) -> Reply:
        with self._lock:
            before, self._holder = self._holder, console
            yields = before in self._yielding
        if before not in (None, console):
            # The keys the other held go with them.
            self.control.halt()
            self.control.note(f"{console} took the controls from {before}")
            if yields and self.started_by() == before:
                # At once, here: not when the client next hears of it (a flood of its
                # own messages must not keep an operator from the robot).
                self.control.stop_mission(
                    Outcome.STOPPED_BY_OPERATOR, f"{console} took the controls from {before}"
                )
        self._tell(self.controls())
        return Reply(True, "you hold the controls")

    def _do_handcontrols(self, request: c.HandControls, console: str) -> Reply:
        """The holder (`console`, which `execute` made sure of) hands the controls on."""
        with self._lock:
            if request.to not in self._consoles:
                return Reply(False, f"refused: {request.to} is not there (nobody has the "
                                    "virtual port open)")  # fmt: skip
            self._holder = request.to
        # The keys the console held go with the controls.
        self.control.halt()
        self.control.note(f"{console} gave the controls to {request.to}")
        self._tell(self.controls())
        return Reply(True, f"{request.to} holds the controls (Ctrl+T takes them back)")

    def _do_view(self, request: c.View, console: str) -> Reply:
        if self.camera is None:
            return Reply(False, "no camera: the robot runs without one")
        self._view(console, request.on)
        return Reply(True)

    def _view(self, console: str, on: bool) -> None:
        with self._lock:
            (self._viewers.add if on else self._viewers.discard)(console)
            if self.camera is not None:
                self.camera.share = self._share if self._viewers else None
            if not self._viewers:
                self._shared = None  # no frame kept for nobody

    def _share(self, image: np.ndarray, fps: float, keypoints: int | None,
               markers: tuple[int, ...] | None) -> None:  # fmt: skip
        """A frame for the consoles that show the camera, on the camera's thread: the
        same image as last time (a robot standing still) is not encoded again."""
        camera = self.camera
        assert camera is not None
        last = self._shared
        if last is not None and last[0] is image:
            frame = replace(last[1], fps=fps, markers=markers)
        else:
            try:
                frame = share(image, camera.source.name, camera.size, fps, keypoints, markers)
            except SharedFrameError as error:
                self.control.note(f"camera: {error}")
                return
        self._shared = (image, frame)
        self._tell(frame)

    def _do_heartbeat(self, request: c.Heartbeat) -> Reply:
        return Reply(True)

    def _do_release(self, request: c.Release, console: str) -> Reply:
        if not self.on_release:
            return Reply(False, "nothing to release: neither a virtual port nor a fleet")
        for release in self.on_release:
            release()
        # Handing the robot back: a console that kept the controls would keep them from
        # what it released.
        self.let_go(console)
        return Reply(True, "what a stop held (the program on the virtual port, the fleet) may "
                           "move the robot again; the controls are free")  # fmt: skip

    def _do_shutdown(self, request: c.Shutdown) -> Reply:
        """Stop the robot; ending the process is the daemon's (service/daemon.py)."""
        self._do_halt(c.Halt())
        return Reply(True, "robot stopped; the daemon is ending")

    def _do_status(self, request: c.Status) -> Reply:
        situation = self.situation()
        return Reply(True, lines=status_lines(situation, situation.consoles))

    def room_here(self) -> str | None:
        """The room the robot stands in by its estimate (a fleet's `lastNodeId`), or None
        without a plan."""
        if self.navigator is None:
            return None
        pose = self.control.estimate().pose
        return self.navigator.room_at((pose.x, pose.y))

    def why_not_through(self, rooms: Sequence[str]) -> str | None:
        """Why the robot could not go through `rooms` in turn, with the doors as they are
        now, or None: an order is checked whole before any of it runs (issue 28)."""
        if self.navigator is None:
            return "no floor plan"
        try:
            self.navigator.check_rooms(rooms)
        except PlanningError as error:
            return str(error)
        return None

    def route(self) -> RouteShown | None:
        """The route on the map now, for a console that attaches mid-mission."""
        return RouteShown.of(self.navigator.state) if self.navigator is not None else None

    def situation(self) -> Situation:
        running, last = self._missions
        controls = self.controls()
        return Situation(
            mission=running,
            holder=controls.holder,
            consoles=controls.consoles,
            last_mission=last,
            recording=self.sessions is not None and self.sessions.recording,
            playing=self.control.playback is not None,
            telemetry=self.telemetry,
            camera_fps=self.camera.rate if self.camera is not None else None,
        )

    def note(self, text: str) -> None:
        """A line for every console."""
        self.control.note(text)


Handler: TypeAlias = Callable[[RobotService, Any, str], Reply]


def _asked(handler: Callable[[RobotService, Any], Reply]) -> Handler:
    """A handler that does not need to know which console asks."""
    return lambda service, request, console: handler(service, request)


# Who answers each request, by its class: a request without a row cannot be sent
# (tests/service/test_robot_service.py checks every one of c.REQUESTS has one).
HANDLERS: dict[type[c.Request], Handler] = {
    c.Press: _asked(RobotService._do_press),
    c.Halt: _asked(RobotService._do_halt),
    c.Speed: _asked(RobotService._do_speed),
    c.Poll: _asked(RobotService._do_poll),
    c.Send: _asked(RobotService._do_send),
    c.SendCommands: _asked(RobotService._do_sendcommands),
    c.Stalk: _asked(RobotService._do_stalk),
    c.Go: _asked(RobotService._do_go),
    c.RunPatrol: RobotService._do_runpatrol,
    c.Follow: _asked(RobotService._do_follow),
    c.Replay: _asked(RobotService._do_replay),
    c.Undock: _asked(RobotService._do_undock),
    c.Teach: _asked(RobotService._do_teach),
    c.Mark: _asked(RobotService._do_mark),
    c.Place: _asked(RobotService._do_place),
    c.Name: _asked(RobotService._do_name),
    c.Done: _asked(RobotService._do_done),
    c.StartMapping: _asked(RobotService._do_startmapping),
    c.SaveMap: _asked(RobotService._do_savemap),
    c.DiscardMap: _asked(RobotService._do_discardmap),
    c.Routes: _asked(RobotService._do_routes),
    c.Pause: _asked(RobotService._do_pause),
    c.Resume: _asked(RobotService._do_resume),
    c.StopMission: RobotService._do_stopmission,
    c.Door: _asked(RobotService._do_door),
    c.Block: _asked(RobotService._do_block),
    c.Record: _asked(RobotService._do_record),
    c.Play: _asked(RobotService._do_play),
    c.Seek: _asked(RobotService._do_seek),
    c.Rate: _asked(RobotService._do_rate),
    c.Step: _asked(RobotService._do_step),
    c.TakeControls: RobotService._do_takecontrols,
    c.HandControls: RobotService._do_handcontrols,
    c.Heartbeat: _asked(RobotService._do_heartbeat),
    c.Release: RobotService._do_release,
    c.Shutdown: _asked(RobotService._do_shutdown),
    c.Status: _asked(RobotService._do_status),
    c.View: RobotService._do_view,
}  # fmt: skip
