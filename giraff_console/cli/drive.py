"""One mission driven to its end from the command line, through the robot service: `go`
and `patrol`, on the robot in this process (runtime/robot.py) or on the daemon's across
its socket, the same way (issue 26). The notes and the progress go to standard error;
how it ended to standard output, in words or as JSON, and in the exit code.

How a mission ends decides the exit code (Outcome, robot/mission.py; outcome_codes.py;
exit_codes.py's numbers, which `--help` and the README say in words).
"""

from __future__ import annotations

import queue
import signal
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import rich.progress
from rich.console import Console

from giraff_console.missions.go_to import GoReport
from giraff_console.missions.names import PATROL_SUFFIX
from giraff_console.missions.patrol_report import PatrolReport
from giraff_console.robot.loop_events import MissionChanged, Note
from giraff_console.robot.mission import TEXT_BAR, Mission, MissionEnd, Outcome, Progress
from giraff_console.robot.telemetry import LinkState, Telemetry
from giraff_console.runtime.robot import Robot
from giraff_console.service import commands as c
from giraff_console.service.events import GoReported, PatrolReported, Reply, ServiceEvent
from giraff_console.service.remote import RemoteRobot
from giraff_console.service.robot_service import HERE

# Seconds between lines of progress when standard error is not a terminal.
PROGRESS_EVERY_S = 5.0
# Seconds of real time to wait for the board's first answer, and for the service's
# answer to the request (planning a route over a large building included).
CONNECT_TIMEOUT_S = 10.0
REPLY_TIMEOUT_S = 60.0
# Seconds a mission's report may follow its end (the service sends it just after).
REPORT_WAIT_S = 2.0


@dataclass(frozen=True)
class Ended:
    """How the mission asked for ended, with its report: a go's, or a patrol's."""

    name: str
    end: MissionEnd
    report: GoReport | PatrolReport | None = None


def print_note(event: ServiceEvent) -> None:
    """The robot's notes on standard error, where `go` and `patrol` say everything."""
    if isinstance(event, Note):
        # One write for the line and its end: notes come from several threads, and
        # print's two writes would let another's run into this one.
        sys.stderr.write(f"giraff-console: {event.text}\n")
        sys.stderr.flush()


def mission_name(request: c.Go | c.RunPatrol) -> str:
    """The name the loop gives the mission `request` starts: a go's room; a patrol's
    name is its file's (missions/patrol.py), however the file was named."""
    if isinstance(request, c.Go):
        return f"go {request.room}"
    return Path(request.name).name.removesuffix(PATROL_SUFFIX)


def report_of(event: ServiceEvent, name: str) -> GoReport | PatrolReport | None:
    """The report of the mission `name` that `event` brings, if it brings one."""
    if isinstance(event, GoReported) and f"go {event.report.room}" == name:
        return event.report
    if isinstance(event, PatrolReported) and event.report.patrol == name:
        return event.report
    return None


def follow(events: queue.Queue[ServiceEvent], name: str, *,
           gone: Callable[[], bool], also: Callable[[ServiceEvent], None] = lambda e: None,
           ) -> Ended | None:  # fmt: skip
    """Wait for the mission `name` to end, drawing its progress on standard error and
    handing every event to `also`; None if the robot goes first (`gone`). It waits
    for the mission's report too (a go's, a patrol's), which the service sends just
    after the end, but not for ever: without it in REPORT_WAIT_S, the end alone."""
    started = False
    ended: MissionEnd | None = None
    ended_at = 0.0
    shown = ProgressShown()
    try:
        while True:
            if ended is not None and time.monotonic() - ended_at > REPORT_WAIT_S:
                return Ended(name, ended)
            try:
                event = events.get(timeout=0.5)
            except queue.Empty:
                if gone():  # and nothing more it said is waiting
                    return Ended(name, ended) if ended is not None else None
                shown.draw(None)
                continue
            also(event)
            if isinstance(event, Telemetry):
                shown.draw(event.mission)
            elif isinstance(event, MissionChanged) and event.name == name:
                if event.running:
                    started = True
                elif event.end is not None and (
                    started or event.end.outcome is Outcome.NOT_STARTED
                ):
                    ended, ended_at = event.end, time.monotonic()
            elif ended is not None:
                report = report_of(event, name)
                if report is not None:
                    return Ended(name, ended, report)
    finally:
        shown.close()


def drive_here(robot: Robot, request: c.Go | c.RunPatrol,
               also: Callable[[ServiceEvent], None] = lambda event: None,
               console: str = HERE) -> Ended | Reply | None:  # fmt: skip
    """Start the robot in this process, ask its service for `request` as soon as the
    board answers, for `console` (attached, if not this console), and follow the
    mission to its end: how it ended, the service's refusal, or None if the board never
    answered. The robot is stopped by the caller's `with`. A signal stops the robot
    first and ends the mission (robot/last_stop.py)."""
    service = robot.service
    events: queue.Queue[ServiceEvent] = queue.Queue()
    replies: queue.Queue[Reply] = queue.Queue()

    def ask() -> None:
        try:
            replies.put(service.execute(request, console))
        except Exception as error:  # a bug must not leave the command waiting
            replies.put(Reply(False, f"failed: {type(error).__name__}: {error}"))
            raise

    service.subscribe(events.put)
    # Stepped, on the loop's thread at the first tick that has the board: the mission is
    # planned and starts at the same virtual time however fast the clock runs, before
    # any frame the eye takes could make a run differ. In real time, from here.
    if not start_on_the_board(robot, ask if robot.stepped is not None else lambda: None):
        return None
    if robot.stepped is None:
        ask()
    try:
        reply = replies.get(timeout=REPLY_TIMEOUT_S)
    except queue.Empty:
        return Reply(False, f"no answer from the robot in {REPLY_TIMEOUT_S:g} s")
    if not reply.ok:
        return reply
    return follow(events, mission_name(request), gone=lambda: not robot.control.running,
                  also=also)  # fmt: skip


def drive_there(remote: RemoteRobot, request: c.Go | c.RunPatrol,
                also: Callable[[ServiceEvent], None] = lambda event: None,
                ) -> Ended | Reply | None:  # fmt: skip
    """Ask the daemon for `request` and follow the mission to its end; None if the
    daemon goes first. Ctrl-C stops the robot, as it does `go` on its own."""
    events: queue.Queue[ServiceEvent] = queue.Queue()
    remote.subscribe(events.put)
    try:
        reply = remote.execute(request, timeout=REPLY_TIMEOUT_S)
        if not reply.ok:
            return reply
        if reply.text:
            print(f"giraff-console: {reply.text}", file=sys.stderr)
        return follow(events, mission_name(request), gone=lambda: remote.gone is not None,
                      also=also)  # fmt: skip
    except KeyboardInterrupt:
        # A stop, which also ends a mission still being planned (RobotService); a second
        # Ctrl-C (or `timeout -s INT`'s) must not cut it short.
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        stopped = remote.execute(c.Halt(), timeout=2.0)
        print(f"giraff-console: {'stopped' if stopped.ok else stopped.text} (Ctrl-C)",
              file=sys.stderr)  # fmt: skip
        raise
    finally:
        remote.close()


def start_on_the_board(robot: Robot, act: Callable[[], None]) -> bool:
    """Guard and start the robot, and `act` on the loop's thread at the first tick that
    has the board: the same virtual time however fast a stepped clock runs. False if the
    board has not answered within CONNECT_TIMEOUT_S."""
    connected = threading.Event()

    def first(event: ServiceEvent) -> None:
        if isinstance(event, Telemetry) and event.link is LinkState.CONNECTED \
                and not connected.is_set():  # fmt: skip
            connected.set()
            robot.service.unsubscribe(first)  # once is all it is for
            act()

    robot.service.subscribe(first)
    robot.guard()
    robot.start()
    return connected.wait(CONNECT_TIMEOUT_S)


def run_mission(robot: Robot, mission: Mission, ended: Callable[[MissionEnd], None],
                meanwhile: Callable[[], None] = lambda: None) -> bool:  # fmt: skip
    """Start the robot, drive `mission` (one the service has no request for: a survey)
    to its end, and stop the robot; False if the board never
    answered. `ended` gets how it ended, on the loop's thread; `meanwhile` is called on
    this thread every half second while it drives, and once after. The robot is
    stopped by the caller's `with`."""
    control, done = robot.control, threading.Event()

    def finish(end: MissionEnd) -> None:
        try:
            ended(end)
        finally:
            done.set()  # whatever the report did: the command must end

    def start() -> None:
        try:
            control.run_mission(mission, finish)
        except Exception:
            # The command must not wait on it.
            finish(MissionEnd(Outcome.HALTED, "stopped: internal error"))
            raise

    if not start_on_the_board(robot, start):
        return False
    shown = ProgressShown()
    try:
        while not done.wait(0.5):
            shown.draw(mission.progress)
            meanwhile()
    finally:
        shown.close()
    meanwhile()
    return True


class ProgressShown:
    """The mission's progress on standard error: drawn with rich on a terminal, else
    its line every few seconds, as logs and the tests read it."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self._clock = clock
        self._terminal = sys.stderr.isatty()
        self._shown_at = clock()
        self._latest: Progress | None = None
        self._bars: rich.progress.Progress | None = None
        self._rows: list[rich.progress.TaskID] = []
        self._shape: list[bool] = []

    def draw(self, progress: Progress | None) -> None:
        if progress is not None:
            self._latest = progress
        if self._clock() - self._shown_at < (0.5 if self._terminal else PROGRESS_EVERY_S):
            return
        self._shown_at = self._clock()
        latest = self._latest
        if latest is None:
            return
        if not self._terminal:
            print(latest.line(), file=sys.stderr)
            return
        self._draw_bars(latest)

    def _draw_bars(self, progress: Progress) -> None:
        # A row for the mission and one for the part under way (a patrol's stop). Notes
        # printed meanwhile go above the rows; so does standard output if it is the
        # terminal too, but not if it is piped (the JSON lines of --json).
        if self._bars is None:
            columns = (
                rich.progress.TextColumn("{task.description}", markup=False),
                rich.progress.BarColumn(bar_width=TEXT_BAR),
                rich.progress.TextColumn("{task.fields[words]}", markup=False),
            )
            self._bars = rich.progress.Progress(
                *columns, console=Console(stderr=True), auto_refresh=False,
                redirect_stdout=sys.stdout.isatty(),
            )  # fmt: skip
            self._bars.start()
        bars = self._bars
        parts = [part for part in (progress, progress.detail) if part is not None]
        if [part.total_m is not None for part in parts] != self._shape:
            # A row's bar measures metres or, without them, pulses; rich cannot take a
            # row's total away again, so the rows are made anew.
            for row in self._rows:
                bars.remove_task(row)
            self._rows = [bars.add_task(part.name, total=part.total_m, words="")
                          for part in parts]  # fmt: skip
            self._shape = [part.total_m is not None for part in parts]
        for row, part in zip(self._rows, parts, strict=True):
            bars.update(row, description=part.name, completed=part.done_m or 0.0,
                        total=part.total_m, words=part.words())  # fmt: skip
        bars.refresh()

    def close(self) -> None:
        if self._bars is not None:
            self._bars.stop()
