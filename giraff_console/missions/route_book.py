"""Teaching, listing and driving routes and patrols (§2.6.1, §2.5), for any front end.

Teaching records a session as well, so that what the operator saw while teaching can be
played back; the route file names that session. A patrol records one too, and saves a
camera snapshot into it at each stop, when its file asks for snapshots and the robot has
a camera to take them with. How each stop went, and the run, are reported as they end
(missions/patrol_report.py): the service tells them to every front end.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from pathlib import Path

from giraff_console.missions.docking import DOCK, ChargeLevels, Recharge, back_to
from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.missions.names import PATROL_SUFFIX, list_patrols, patrol_file
from giraff_console.missions.patrol import PatrolError, PatrolRun, StopReached, load_patrol
from giraff_console.missions.patrol_log import PatrolRunLog
from giraff_console.missions.patrol_report import PatrolReporter, PatrolReports
from giraff_console.missions.route import (
    Route,
    RouteError,
    RouteTeacher,
    check_name,
    list_routes,
    load_route,
    save_route,
)
from giraff_console.missions.route_replay import RouteReplay, replay_refusal
from giraff_console.missions.sessions import Sessions
from giraff_console.missions.undock import Undock
from giraff_console.planning.room_graph import PlanningError
from giraff_console.protocol.charger import ChargeStatus
from giraff_console.recording.session import SessionRecorder
from giraff_console.robot.battery import Battery
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.loop_events import ExchangeTap, LoopEvent
from giraff_console.robot.mission import MissionEnd
from giraff_console.robot.odometry import Pose
from giraff_console.robot.telemetry import LinkState, Telemetry


class RouteBook:
    """The routes in one directory, and the one being taught; outcomes go to `report`."""

    def __init__(
        self,
        control: ControlLoop,
        sessions: Sessions,
        directory: Path,
        report: Callable[[str], None],
        drives: DriveSetup | None = None,
        charge: ChargeLevels | None = None,
        undock_distance: float = 0.3,
        runs: Path | None = None,
        examples: Path | None = None,
    ) -> None:
        """`drives` builds the routes followed closed-loop and, with a floor plan, the
        patrols' ways to rooms and the dock (without it: no plan, the loop's own pose and
        estimate, the default limits); `charge` says when a patrol goes to charge, and
        `undock_distance` how far it backs out after. `runs` is the folder where each
        patrol's run is logged (missions/patrol_log.py); None logs none. `examples` is
        the folder of the example patrols shipped with the package, run when `directory`
        has no patrol of that name (data_folders.example_routes)."""
        self.control = control
        if drives is None:
            drives = DriveSetup.on_loop(control, None, notify=lambda text: self.report(text))
        self.drives = drives
        self.navigator = drives.navigator
        self.limits = drives.limits
        self.charge = charge or ChargeLevels()
        self.undock_distance = undock_distance
        self._battery: Battery | None = None
        self.sessions = sessions
        self.directory = directory
        self.examples = examples
        self.runs = runs
        self.report = report
        self.teacher: RouteTeacher | None = None
        # The recording this book started, for teaching or a patrol; it stops it, and
        # only it, when that is over.
        self._recording: SessionRecorder | None = None
        self._owner: object = None
        # The owner of a recording made for teaching.
        self._teaching = object()
        # Recordings start and stop on the UI thread and, when a patrol ends, on another.
        self._lock = threading.Lock()
        self._link = LinkState.LOST
        control.subscribe(self._telemetry)

    # -- teaching -----------------------------------------------------------------------

    def teach(self, name: str) -> bool:
        """Start teaching route `name`: the operator drives, `mark` names places."""
        if self.teacher is not None:
            self.report(f"already teaching {self.teacher.name}: `done` saves it first")
            return False
        if self.control.playback is not None or self.control.mission is not None:
            self.report("not teaching: the robot is busy with a playback or a mission")
            return False
        settings = self.control.teleop.board_settings
        if self._link is not LinkState.CONNECTED or not settings:
            self.report("not teaching: the board's settings are unknown until it answers")
            return False
        try:
            check_name(name, "route")
        except RouteError as error:
            self.report(f"not teaching: {error}")
            return False
        session = self._record(owner=self._teaching)
        self.teacher = RouteTeacher(name, self.control.clock.now(), self.control.pose,
                                    settings, str(session) if session else None)  # fmt: skip
        self.control.subscribe(ExchangeTap(self.teacher.observe_exchange))
        # A playback now would feed recorded commands to the route being taught.
        self.sessions.busy = f"teaching route {name}: `done` first"
        self.report(f"teaching route {name}: drive it, `mark PLACE` names a place, `done` saves")
        return True

    def mark(self, place: str) -> None:
        if self.teacher is None:
            self.report("not teaching: `teach NAME` first")
            return
        try:
            mark = self.teacher.mark(place, self.control.clock.now(), self.control.pose)
        except RouteError as error:
            self.report(f"refused: {error}")
            return
        self.report(f"marked {mark.name} at X={mark.x:.2f} Y={mark.y:.2f}")

    def done(self) -> Path | None:
        """Finish teaching and save the route; its path, or None if it was not saved."""
        teacher, self.teacher = self.teacher, None
        if teacher is None:
            self.report("not teaching: nothing to save")
            return None
        self.control.unsubscribe(ExchangeTap(teacher.observe_exchange))
        self.sessions.busy = None
        self._stop_recording(owner=self._teaching)
        route = teacher.finish(self.control.clock.now(), self.control.pose)
        try:
            path = save_route(route, self.directory)
        except (OSError, RouteError) as error:
            self.report(f"route {route.name} NOT saved: {error}")
            return None
        self.report(f"route {route.name} saved to {path}: {route.duration:.0f} s, "
                    f"{len(route.commands)} commands, marks: "
                    f"{', '.join(m.name for m in route.marks) or 'none'}")  # fmt: skip
        return path

    # -- the book -----------------------------------------------------------------------

    def listing(self) -> list[str]:
        """Lines naming every route and patrol."""
        routes = list_routes(self.directory)
        patrols = list_patrols(self.directory)
        # The examples the operator's own patrols do not hide (patrol_file).
        examples = [name for name in self._examples() if name not in patrols]
        shipped = [f"example patrols: {', '.join(examples)}"] if examples else []
        if not routes and not patrols:
            return [f"no routes in {self.directory}: `teach NAME` makes one", *shipped]
        return [f"routes: {', '.join(routes) or 'none'}",
                f"patrols: {', '.join(patrols) or 'none'}", *shipped]  # fmt: skip

    def patrols_going_to(self, room: str) -> list[str]:
        """The patrols with a stop in `room`: a patrol names rooms by their ids, and
        looks them up as each leg starts."""
        going = []
        for name in list_patrols(self.directory):
            try:
                patrol = load_patrol(self.directory / f"{name}{PATROL_SUFFIX}")
            except PatrolError:
                continue  # one that does not load says so when it is run
            if any(stop.room == room for stop in patrol.stops):
                going.append(name)
        return going

    def replay(self, name: str) -> bool:
        """Drive route `name` again, open-loop, with its original timing."""
        route = self._load(name)
        if route is None or not self._free():
            return False
        refusal = replay_refusal(route, self.control.estimate(), f"replay-route {name}")
        if refusal is not None:
            self.report(f"not replaying {name}: {refusal}")
            return False
        self.control.run_mission(RouteReplay(route))
        return True

    def follow(self, name: str) -> bool:
        """Drive route `name` along its taught path, closed-loop, from where the robot
        stands (it must be near the route's start)."""
        route = self._load(name)
        if route is None or not self._free():
            return False
        try:
            mission = self.drives.follow(route)
        except PlanningError as error:
            self.report(f"not following {name}: {error}")
            return False
        self.control.run_mission(mission)
        return True

    def undock(self, distance: float) -> bool:
        """Back out of the dock `distance` metres and turn round, in steps the console
        streams (missions/undock.py), never with the board's own `set undock`. Backing
        out drives blind, so the robot must be on its charger by the board's word, or
        stand where someone or a marker says (a daemon restarted off its dock would
        otherwise reverse into whatever is behind it)."""
        if not self._free():
            return False
        docked = self._battery is not None and self._battery.status is not ChargeStatus.NOT_DOCKED
        estimate = self.control.estimate()
        if not (docked or estimate.found or estimate.basis.verified):
            self.report("not undocking: the board does not say the robot is on its charger, "
                        "and where it stands is only assumed; drive it by hand")  # fmt: skip
            return False
        self.control.run_mission(Undock(distance, self.limits))
        return True

    def _recharge(self) -> Recharge | None:
        """What a patrol needs to charge on the way; None without a floor plan with a
        start room, where the dock is."""
        if self.navigator is None or self.navigator.start_pose is None:
            return None
        return Recharge(
            battery=lambda: self._battery,
            levels=self.charge,
            dock=lambda: self.drives.go(DOCK),
            undock=lambda: Undock(self.undock_distance, self.limits),
            back_to=lambda pose: self.drives.arrive("where it left off", back_to(pose)),
        )

    def patrol(self, name: str, *, by: str = "a console", scheduled: bool = False,
               reports: PatrolReports | None = None) -> bool:  # fmt: skip
        """Run patrol `name` from `<name>.patrol.yaml` in the routes folder, else from
        the examples shipped with the package; `by` who asked, for its log. The routes it
        drives are looked for beside its file. Each stop, and the run at its end, is
        reported to `reports` (missions/patrol_report.py). It takes its snapshots, when
        its file asks for them, with the camera: without one it records no session."""
        if not self._free():
            return False
        folders = [self.directory] if self.examples is None else [self.directory, self.examples]
        path = patrol_file(name, folders)
        try:
            patrol = load_patrol(path)
        except (OSError, PatrolError, RouteError) as error:
            self.report(f"no patrol {name}: {error}")
            return False
        routes = {}
        for stop in patrol.stops:
            if stop.route is None:
                continue
            route = self._load(stop.route, path.parent)
            if route is None:
                return False
            routes[stop.route] = route
        go = self.drives.go if self.navigator is not None else None
        snapshots = patrol.snapshots and self.sessions.camera is not None
        log = RunLog(self.runs, self.report, self.sessions if snapshots else None)
        control = self.control
        plan = self.navigator.plan if self.navigator is not None else None
        told = PatrolReporter(patrol, routes, control, plan, reports) if reports else None

        def reached(stop: StopReached) -> None:
            log.reached(stop, control.pose)
            if told is not None:
                told.reached(stop)

        try:
            run = PatrolRun(patrol, routes, reached, go=go, follow=self.drives.follow,
                            recharge=self._recharge(), pose=lambda: control.pose,
                            notify=self.report, estimate=control.estimate)  # fmt: skip
        except PatrolError as error:
            self.report(str(error))
            return False
        if told is not None:
            told.run = run
        if snapshots:
            self._record(owner=run)
        log.start(patrol.name, scheduled=scheduled, by=by)

        def ended(end: MissionEnd) -> None:
            if told is not None:
                told.ended(end)
            # On the loop's thread: closing the files may take a while on a slow disk.
            _in_background(lambda: log.end(end, log.reached_count))
            _in_background(lambda: self._stop_recording(owner=run))

        self.control.run_mission(run, ended)
        return True

    # -- helpers ------------------------------------------------------------------------

    def _load(self, name: str, folder: Path | None = None) -> Route | None:
        """Route `name` from `folder`, by default the routes folder; None, said, if it
        cannot be used."""
        folder = self.directory if folder is None else folder
        try:
            return load_route(folder / f"{name}.yaml")
        except FileNotFoundError:
            self.report(f"no route {name} in {folder}")
        except (OSError, RouteError) as error:
            self.report(f"route {name} cannot be used: {error}")
        return None

    def _examples(self) -> list[str]:
        return list_patrols(self.examples) if self.examples is not None else []

    def _free(self) -> bool:
        if self.teacher is not None:
            self.report(f"teaching {self.teacher.name}: `done` first")
            return False
        if self.control.playback is not None:
            self.report("a playback is running: `play stop` returns to live first")
            return False
        return True

    def _record(self, owner: object) -> Path | None:
        """The session being recorded, or a new one; `owner` (a teacher, a patrol run)
        stops it when done, unless the operator started it. A recording this book started
        passes to the new owner, as when a patrol is started again."""
        with self._lock:
            recorder = self.sessions.recorder
            if recorder is not None:
                if recorder is self._recording:
                    self._owner = owner
                return recorder.path
            path = self.sessions.start_recording()
            self._recording, self._owner = self.sessions.recorder, owner
            return path

    def _stop_recording(self, owner: object) -> None:
        """Stop the recording this book started, if `owner` still owns it."""
        with self._lock:
            recorder = self._recording
            if recorder is None or self._owner is not owner:
                return
            self._recording = self._owner = None
        self.sessions.stop_recording(only=recorder)

    def _telemetry(self, event: LoopEvent) -> None:
        """After each tick: the link and the battery, and the pose of a route being taught."""
        if not isinstance(event, Telemetry):
            return
        self._link = event.link
        self._battery = event.battery
        teacher = self.teacher
        if teacher is not None:
            teacher.observe_pose(self.control.clock.now(), event.pose)


class RunLog:
    """A patrol run as it goes, in its log (when the book has a folder for them), with a
    snapshot at each stop (when the patrol takes them) and a note of each problem."""

    def __init__(self, folder: Path | None, report: Callable[[str], None],
                 sessions: Sessions | None) -> None:  # fmt: skip
        self.log = PatrolRunLog(folder) if folder is not None else None
        self.report = report
        self.sessions = sessions
        self.reached_count = 0
        # Stops reported before the log's first line: a first stop whose way cannot be
        # planned fails as the run is made, and is logged once the run has started.
        self._early: list[dict[str, object]] | None = []

    def start(self, patrol: str, *, scheduled: bool, by: str) -> None:
        early, self._early = self._early or [], None
        if self.log is not None:
            self._told(self.log.start(patrol, scheduled=scheduled, by=by))
            for record in early:
                self._told(self.log.stop(record))

    def reached(self, stop: StopReached, pose: Pose) -> None:
        """On the loop's thread, as the robot comes to rest: the snapshot is encoded and
        written on another."""
        self.reached_count += stop.reached
        record: dict[str, object] = {
            "round": stop.round, "stop": stop.stop_index, "place": stop.route_name,
            "outcome": stop.outcome.value, "detail": stop.detail,
            "pose_estimate": [round(pose.x, 3), round(pose.y, 3),
                              round(math.degrees(pose.heading), 1)],
        }  # fmt: skip
        if self._early is not None:
            self._early.append(record)
        elif self.log is not None:
            self._told(self.log.stop(record))
        sessions = self.sessions
        if sessions is None or not stop.reached:
            return
        label = f"round{stop.round}-stop{stop.stop_index}-{stop.route_name}"

        def snapshot() -> None:
            path = sessions.snapshot(label)
            if path is None:
                return
            self.report(f"snapshot {path.name}")
            if self.log is not None:
                self._told(self.log.snapshot(path))

        _in_background(snapshot)

    def end(self, end: MissionEnd, stops: int) -> None:
        if self.log is not None:
            arrived = end.outcome.arrived
            self._told(self.log.end(end.why, arrived=arrived, stops=stops))

    def _told(self, problem: str | None) -> None:
        # The first problem only: a full disk would otherwise say so at every stop.
        if problem is not None and self.log is not None and problem == self.log.problem:
            self.report(f"patrol log: {problem}; the patrol carries on")


def _in_background(work: Callable[[], None]) -> None:
    """Disk work that the control loop must not wait for."""
    threading.Thread(target=work, name="route-book", daemon=True).start()
