"""The control loop: the one owner of the link (design.md).

At a fixed rate, off the UI thread, it polls `bulk_data`, updates the odometry, runs
teleop and publishes an immutable `Telemetry` snapshot. That snapshot, every exchange
with the board and every note for the operator go out as one stream of events
(loop_events.py) to whoever has subscribed. Anything else that must talk to the board,
such as a typed command, is queued to it and runs between ticks. A key press wakes the
loop at once, so the first motion command does not wait for a tick.

When the board stops answering the loop reports LINK LOST and reconnects with
back-off; the first thing it sends to a reconnected board is a stop. Then it probes
which board it is (link/board_probe.py): the thesis's or a later firmware, whose wheel
readings the odometry must take differently (odometry_feed.py), whose battery and
height stalk it reads every half second (board_gauges.py), and, on Giraff-X, which takes
a curve as one `twm` (twm.py).

Every way the console can end or fail reaches the loop as `emergency_stop` (design.md):
from a signal, an exception on another thread or a quit. It only sets a flag and wakes
the loop, so it is safe anywhere, and from then on nothing but the stop is sent: the
tick that is under way sends no more renewals, and the next one stops the robot from a
fresh poll, on the loop's own thread, before anything else.

Instead of teleop the loop may run a mission (a route, a patrol), or play a recorded
session back, in which case nothing but a stop goes to the robot (§3.2.1.1). Since
everything that reaches the board passes through here, this module is longer than most.
"""

from __future__ import annotations

import collections
import logging
import math
import queue
import sys
import threading
import time
from collections.abc import Callable

import numpy as np

from giraff_console.clock import Clock, VirtualClock
from giraff_console.link import (
    BoardFeatures,
    BoardLink,
    Exchange,
    LinkError,
    MotorState,
    probe,
)
from giraff_console.protocol.errors import (
    BoardError,
    BoardRebootedError,
    CommandError,
    GiraffError,
)
from giraff_console.protocol.kinematics import WHEEL_BASE_M
from giraff_console.recording.playback import Playback
from giraff_console.robot.battery import Battery
from giraff_console.robot.board_gauges import BoardGauges
from giraff_console.robot.command_guard import check_command
from giraff_console.robot.deadman import Deadman, Intent
from giraff_console.robot.localisation import Estimate, Localisation, PoseBasis
from giraff_console.robot.loop_events import Listener, LoopEvent, MissionChanged, Note
from giraff_console.robot.mission import Judged, Mission, MissionEnd, Outcome
from giraff_console.robot.odometry import Odometry, Pose
from giraff_console.robot.odometry_feed import OdometryFeed
from giraff_console.robot.realtime import run_promptly
from giraff_console.robot.replay import Replayer
from giraff_console.robot.safety import rotation_wheel_speed, stop_robot
from giraff_console.robot.telemetry import LinkState, Telemetry
from giraff_console.robot.teleop import BLOCKED_S, Teleop
from giraff_console.robot.wheel_odometers import AUTO, Reading

log = logging.getLogger(__name__)

DEFAULT_RATE_HZ = 20.0
BACKOFF_S = (0.5, 1.0, 2.0, 4.0)

Connect = Callable[[], BoardLink]
BoardJob = Callable[[BoardLink], object]
JobDone = Callable[[object], None]
MissionEnded = Callable[[MissionEnd], None]


class ControlLoop:
    """Runs the robot from its own thread; all methods are safe from any thread."""

    def __init__(self, connect: Connect, *, teleop: Teleop, deadman: Deadman,
                 rate_hz: float = DEFAULT_RATE_HZ, clock: Clock,
                 wheel_base: float = WHEEL_BASE_M, odometers: str = AUTO,
                 twm: str = AUTO) -> None:  # fmt: skip
        """`wheel_base`, `odometers` and `twm` are the `[board]` settings: the robot's
        wheel base, how its wheels' travel is read (auto, totals, increments, encoders)
        and whether curves go out as one twm (auto, on, off)."""
        self.connect = connect
        self.teleop = teleop
        self.deadman = deadman
        self.period = 1.0 / rate_hz
        self.clock = clock
        # Whoever listens to the loop (loop_events.py): replaced whole, never changed in
        # place, so the loop's thread reads it without a lock; the lock keeps two
        # subscriptions at once from losing one.
        # Each with whether it is vital: the operator's only way of being told.
        self._listeners: tuple[tuple[Listener, bool], ...] = ()
        self._listeners_lock = threading.Lock()
        self._listener_failures: collections.Counter[Listener] = collections.Counter()
        initial = Reading.TOTALS if odometers == AUTO else Reading(odometers)
        self.odometry = Odometry(wheel_base=wheel_base, reading=initial)
        self.feed = OdometryFeed(self.odometry, odometers, self.note, twm)
        self.gauges = BoardGauges(self.note)
        # Where the robot is: the odometry, corrected by the markers the camera sees
        # once the plan's markers are given to it (localisation.use_markers).
        self.localisation = Localisation(self.odometry, now=clock.now, report=self.note)
        self.autopoll = True
        self.link: BoardLink | None = None
        self._jobs: queue.SimpleQueue[tuple[BoardJob, JobDone, bool]] = queue.SimpleQueue()
        self._wake = threading.Event()
        self._running = False
        self._thread: threading.Thread | None = None
        self._state: MotorState | None = None
        self._retry_at = 0.0
        self._failures = 0
        self._rate = 0.0
        self._late = 0.0
        self._recent: collections.deque[float] = collections.deque()
        self._estop = False
        self._crashes = 0
        self._requests: queue.SimpleQueue[Callable[[], None]] = queue.SimpleQueue()
        self._replayer: Replayer | None = None
        self._playback_ended: Callable[[], None] = lambda: None
        self._seek_to: float | None = None
        self._mission: Mission | None = None
        self._mission_ended: MissionEnded = lambda end: None
        # Set by emergency_stop: why, and whether the loop is to close after the stop.
        self._halt: tuple[str, bool] | None = None
        self._halt_lock = threading.Lock()
        # How the loop's thread is scheduled (robot/realtime.py), once it runs.
        self.priority = "not running"
        self._starting_lock = threading.Lock()
        self._starting = 0
        # The mission's end asked and not yet come to (stop_mission), as (outcome, why).
        self._end_queued: tuple[Outcome, str] | None = None
        self._closed = threading.Event()

    # -- from other threads -------------------------------------------------------------

    def start(self, stepped: float | None = None) -> None:
        """Run the loop on its own thread. With `stepped`, the clock must be a
        VirtualClock, which the loop moves on itself, `stepped` times faster than real
        time (math.inf: as fast as it can); see `_run_stepped`."""
        # A busy screen holds the GIL for up to the switch interval (5 ms by default)
        # before this thread gets it; 1 ms keeps ticks on time.
        sys.setswitchinterval(0.001)
        self._running = True
        run = self._run if stepped is None else lambda: self._run_stepped(stepped)
        self._thread = threading.Thread(target=run, name="control-loop", daemon=True)
        self._thread.start()
        if (stepped is None or stepped <= 1) and self._thread.native_id is not None:
            # A loop that keeps real time (the real clock, or a simulator's virtual one
            # stepped at real time, as the daemon's is) sleeps between ticks and must
            # tick on time: it is a robot's loop. One stepped faster runs as fast as it
            # is let, a batch job that must not take a CPU from everything else.
            self.priority = run_promptly(self._thread.native_id)
            log.info("control loop: %s", self.priority)

    def stop(self, why: str = "console closing", timeout: float = 1.5) -> bool:
        """Stop the robot and close the port, from the loop's own thread if it runs;
        then end the loop. True once the robot was commanded to stop and the port closed
        within `timeout` seconds."""
        thread = self._thread
        if thread is not None and thread.is_alive() and thread is not threading.current_thread():
            self.emergency_stop(why, close=True)
            if self._closed.wait(timeout):
                thread.join(timeout)
                return True
            log.error("the control loop is stuck: the robot is stopped from another thread")
        self._running = False
        self._wake.set()
        # The loop is not running (or is stuck): stop the robot from here.
        self.shutdown()
        return thread is None or not thread.is_alive()

    def subscribe(self, listener: Listener, *, vital: bool = False) -> None:
        """From now on `listener` gets every snapshot and every exchange, on whatever
        link is open or played back, and every note, on the thread that made them: the
        loop's, but for notes made elsewhere and the last stop sent by `stop` when the
        loop is not running. One that raises is logged and the others still hear; a
        `vital` one (the screen, or standard error without it: the operator's only way
        of being told) that raises stops the robot, since whatever it drives from then
        on the operator would not see (design.md: every error reaches the loop as "stop
        now")."""
        with self._listeners_lock:
            self._listeners = (*self._listeners, (listener, vital))

    def unsubscribe(self, listener: Listener) -> None:
        """`listener` (or one equal to it) gets nothing more, but for an event the loop
        is handing out as this is called; nothing happens if it was not subscribed."""
        with self._listeners_lock:
            listeners = list(self._listeners)
            for index, (subscribed, _) in enumerate(listeners):
                if subscribed == listener:
                    del listeners[index]
                    self._listeners = tuple(listeners)
                    break

    def note(self, text: str) -> None:
        """Tell every listener `text`, a line for the operator."""
        self._tell(Note(text))

    def emergency_stop(self, why: str, close: bool = False) -> None:
        """Stop the robot now, from any thread: nothing more but the stop goes to the
        board, and whatever was driving is over. With `close` the loop then closes the
        port and ends."""
        with self._halt_lock:
            held = self._halt
            self._halt = (why, close or (held is not None and held[1]))
        self._wake.set()

    def wait_closed(self, timeout: float) -> bool:
        """Wait until the loop has stopped the robot and closed the port after
        `emergency_stop(close=True)`; False if it has not within `timeout` seconds."""
        return self._closed.wait(timeout)

    def shutdown(self) -> None:
        """Stop the robot and close the port; safe to call more than once."""
        link, self.link = self.link, None
        if link is not None:
            stop_robot(link)
            link.close()

    def press(self, intent: Intent) -> None:
        """A key event. A first press wakes the loop at once; repeats wait for the tick."""
        if self.deadman.press(intent):
            self._wake.set()

    def halt(self) -> None:
        """Let go of the keys: teleop brakes to a stop on the next tick."""
        self.deadman.release()
        self._wake.set()

    def submit(self, job: BoardJob, done: JobDone = lambda result: None, *,
               stop: bool = False) -> None:  # fmt: skip
        """Run `job(link)` on the loop's thread; `done` gets its result or the GiraffError.

        Only a job that stops the robot (`stop`) is run during a playback, when nothing
        else may reach the robot.
        """
        self._jobs.put((job, done, stop))
        self._wake.set()

    def play(self, playback: Playback, ended: Callable[[], None] = lambda: None) -> None:
        """Play a session back: the robot is stopped, then nothing more is sent to it.

        `ended` is called, on the loop's thread, when the console is live again.
        """
        self.between_ticks(lambda: self._start_playback(playback, ended))

    def stop_playback(self) -> None:
        """Back to live."""
        self.between_ticks(lambda: self._end_playback("playback stopped; live again"))

    def seek(self, offset: float) -> None:
        """Move the playback to `offset` seconds into the session."""

        # Seeks asked for faster than the loop makes them (a held key) come to one.
        pending, self._seek_to = self._seek_to, offset
        if pending is not None:
            return

        def seek() -> None:
            target, self._seek_to = self._seek_to, None
            if self._replayer is not None and target is not None:
                self._replayer.seek(self.clock.now(), target)

        self.between_ticks(seek)

    @property
    def stopping(self) -> bool:
        """Whether an emergency stop is under way: nothing typed goes out meanwhile."""
        return self._halt is not None

    @property
    def playback(self) -> Playback | None:
        replayer = self._replayer
        return None if replayer is None else replayer.playback

    def run_mission(self, mission: Mission, ended: MissionEnded = lambda end: None) -> None:
        """Let `mission` drive; the keys, ESTOP, a lost link or `stop_mission` end it.

        `ended` is called with how it ended, on the loop's thread, when it is over.
        """

        def start() -> None:
            try:
                self._start_mission(mission, ended)
            finally:
                with self._starting_lock:
                    self._starting -= 1

        with self._starting_lock:
            self._starting += 1
            # A stop asked from now on must end this mission, not ride on one asked
            # before it (stop_mission).
            self._end_queued = None
            self.between_ticks(start)

    @property
    def running(self) -> bool:
        """Whether the loop's thread runs (it ends once `stop` or a closing stop is done)."""
        thread = self._thread
        return thread is not None and thread.is_alive()

    @property
    def missions_starting(self) -> int:
        """Missions handed to the loop that it has not yet started or refused: `mission`
        does not show them, and what must not change under a mission waits for them."""
        return self._starting

    def stop_mission(self, outcome: Outcome = Outcome.STOPPED_BY_OPERATOR,
                     why: str = "stopped by the operator") -> None:  # fmt: skip
        """End the mission (the robot stops) with `outcome`, and `why` for the operator.

        The same stop asked again before the loop has come to it, with no mission handed
        to the loop since, is that one: a stop asked thousands of times (a console in a
        loop, a flood, issue 30) is one request for the loop, not thousands of ticks."""
        asked = (outcome, why)

        def end() -> None:
            with self._starting_lock:
                if self._end_queued == asked:
                    self._end_queued = None
            self._end_mission(outcome, why)

        with self._starting_lock:
            if self._end_queued == asked:
                return
            self._end_queued = asked
            self.between_ticks(end)

    def pause_mission(self, paused: bool) -> None:
        """Pause (the robot stops) or resume the mission."""

        def pause() -> None:
            if self._mission is None:
                return
            if paused:
                self._mission.pause(self.clock.now())
                self._stop_robot()
            else:
                self._mission.resume(self.clock.now())
            self.note(f"{self._mission.name} {'paused' if paused else 'resumed'}")

        self.between_ticks(pause)

    @property
    def mission(self) -> Mission | None:
        return self._mission

    @property
    def pose(self) -> Pose:
        """Where the robot is believed to be: what missions, teaching and the screen
        go by (the loop's thread moves it on; a read from elsewhere is a snapshot)."""
        return self.localisation.pose

    def estimate(self) -> Estimate:
        """The pose with how well it is known (the loop's thread; see `pose`)."""
        return self.localisation.estimate()

    def place(self, pose: Pose, basis: PoseBasis = PoseBasis.ASSUMED,
              covariance: np.ndarray | None = None) -> None:  # fmt: skip
        """The robot stands at `pose`, as `basis` says, known to `covariance` (the
        dock's few centimetres by default): before the loop starts, or from its thread."""
        self.localisation.place(pose, covariance, basis)

    @property
    def board(self) -> BoardFeatures | None:
        """What the probe found on the board connected; None while there is none."""
        return self.feed.features

    @property
    def battery(self) -> Battery | None:
        """The battery as a later board last reported it; None until then, or on a
        board without a charger."""
        return self.gauges.battery

    def between_ticks(self, change: Callable[[], None]) -> None:
        """Run `change` on the loop's thread before its next tick: changes of what the
        loop does, and anything that must not fall between a poll and its use."""
        self._requests.put(change)
        self._wake.set()

    # -- the loop -----------------------------------------------------------------------

    def _run(self) -> None:
        next_tick = self.clock.now()
        while self._running:
            # Cleared before the tick, so that a key pressed during it wakes the next wait.
            self._wake.clear()
            now = self.clock.now()
            early = now < next_tick
            if not early:
                # A scheduled tick: note how late it is, keep to the fixed rate.
                self._late = now - next_tick
                next_tick = max(next_tick + self.period, now)
            self.tick(early=early)
            self._wake.wait(max(0.0, min(next_tick, self.next_due()) - self.clock.now()))

    def _run_stepped(self, speed: float) -> None:
        """The loop on a virtual clock (a simulator's `--sim-speed`): tick, move the
        clock on to the next tick or to what a mission asks for, and keep to that step
        divided by `speed` in real time. The ticks fall at the same virtual times
        whatever the speed, so a faster clock changes nothing but the wall time.

        The real schedule is kept from one tick to the next, not a step after each
        tick's work: the simulated camera looks for markers inside the tick, and a full
        step after it made a 20 Hz loop tick 10 to 14 times a second (issue 15). How late
        a tick starts against that schedule is its lateness, as on the real clock."""
        clock = self.clock
        assert isinstance(clock, VirtualClock), "a stepped loop needs a VirtualClock"
        next_tick = clock.now()
        real_next = time.monotonic()
        while self._running:
            now = clock.now()
            early = now < next_tick
            if not early:
                next_tick += self.period
                if speed != math.inf:
                    self._late = max(0.0, time.monotonic() - real_next)
            self.tick(early=early)
            step = max(0.0, min(next_tick, self.next_due()) - clock.now())
            if speed != math.inf:
                # Behind by more than a tick (a busy machine): go on from now, rather
                # than run ticks back to back to catch up.
                real_next = max(real_next + step / speed, time.monotonic() - self.period)
                if self._wake.wait(max(0.0, real_next - time.monotonic())):
                    # Woken early (a key, a job): only the real time gone by passes on
                    # the virtual clock, or every request would speed the simulator up.
                    early_by = max(0.0, real_next - time.monotonic())
                    step = max(0.0, step - early_by * speed)
                    real_next -= early_by
                self._wake.clear()
            clock.advance(step)

    def next_due(self) -> float:
        """When a playback or a mission next wants a tick, if before the next one; inf if
        neither does."""
        source = self._replayer.playback if self._replayer is not None else self._mission
        due = source.next_due() if source is not None else None
        return math.inf if due is None else due

    def tick(self, early: bool = False) -> None:
        """One control cycle; public so that tests can step the loop on a virtual clock.

        `early` marks a tick that a key press brought forward. A bug in the cycle stops
        the robot rather than the loop.
        """
        try:
            self._tick(early)
        except Exception:
            log.exception("control tick failed")
            self._crash()

    def _tick(self, early: bool) -> None:
        if self._halt is not None:
            self._stop_now()
            return
        now = self.clock.now()
        self._recent.append(now)
        while self._recent[0] < now - 1.0:
            self._recent.popleft()
        self._rate = float(len(self._recent))
        self._run_requests()
        if self._replayer is not None:
            self._play(now)
            self._publish()
            return
        if self.link is None:
            # Nothing drives by itself once the link is back: the operator starts it again.
            self._end_mission(Outcome.LINK_LOST, "stopped: no link to the board", stop=False)
        if self.link is None and not self._reconnect():
            self._fail_jobs()
            self._publish()
            return
        assert self.link is not None
        try:
            self._run_jobs(self.link)
            intent = self.deadman.held()
            if intent is not None and self._mission is not None:
                took = "stopped: the operator took the keys"
                self._end_mission(Outcome.STOPPED_BY_OPERATOR, took, stop=False)
            driving = intent is not None or self.teleop.active
            # A key that brings a tick forward acts on the state polled less than a period
            # ago: polling again would only delay the first command.
            state = self._state
            fresh = state is not None and self.clock.now() - state.received_at < self.period
            polling = bool(self.autopoll or driving or self._mission)
            if polling and not (early and fresh):
                state = self._state = self.feed.poll(self.link)
                self._note_estop(state)
                # A pose that jumped, or cannot be trusted: a mission must not steer by it.
                why = self.feed.mission_stop()
                if why is not None:
                    self._end_mission(Outcome.LOST, why)
            # The wheels' travel since the last tick, then the markers seen meanwhile,
            # before anything steers by the pose.
            self.localisation.follow()
            self.localisation.correct()
            if driving and state is not None:
                if state.estop:
                    self.deadman.release()
                self._step_teleop(self.link, state)
            elif self._mission is not None:
                self._step_mission(self.link, state)
            if polling and self._halt is None:  # stopping now: nothing more goes out
                self.gauges.poll(self.link, self.clock.now())
        except LinkError as error:
            self.note(f"LINK LOST: {error}")
            self._end_mission(Outcome.LINK_LOST, "stopped: the link to the board was lost",
                              stop=False)  # fmt: skip
            self._drop_link()
        except BoardRebootedError as error:
            self._end_mission(Outcome.LINK_LOST, "stopped: the board restarted", stop=False)
            self._board_restarted(error)
        except GiraffError as error:
            # A poll the board refuses, say: a mission must not go on blind, nor be
            # tried again twenty times a second.
            self.note(str(error))
            self._end_mission(Outcome.REFUSED, f"stopped: {error}")
        self._publish()

    def _step_teleop(self, link: BoardLink, state: MotorState) -> None:
        """Send what the held key asks for, each command within the limits (the one
        guard every path to the board passes); a command refused, by the guard or by the
        board, ends the driving rather than being asked again twenty times a second."""
        speed = self._speed_bound(state)
        commands = list(self.teleop.step(self.deadman.held(), state))
        if self.teleop.newly_blocked:
            self.note("blocked: the keys drive, but the wheels have not turned for "
                      f"{BLOCKED_S:g} s; something is in the way")  # fmt: skip
        for command in self.feed.moves(commands, self.teleop.board_settings):
            if self._halt is not None:
                return  # stopping now: no more renewals
            try:
                check_command(command, self.teleop.limits, self.teleop.board_settings, speed)
                link.send(command)
            except (CommandError, BoardError) as error:
                self.deadman.release()
                self.note(f"driving stopped: {command} refused: {error}")
                self._stop_robot()
                return

    def _step_mission(self, link: BoardLink, state: MotorState | None) -> None:
        """Send what the mission asks for now, each command within the limits."""
        mission = self._mission
        assert mission is not None
        if state is not None and state.estop:
            self._end_mission(Outcome.ESTOP, "stopped by ESTOP", stop=False)
            return
        speed = self._speed_bound(state)
        commands = list(mission.step(self.clock.now(), state))
        for command in self.feed.moves(commands, self.teleop.board_settings):
            if self._halt is not None:
                return  # stopping now: no more renewals
            try:
                check_command(command, self.teleop.limits, self.teleop.board_settings, speed)
            except CommandError as error:
                self._end_mission(Outcome.REFUSED, f"stopped: {command} refused: {error}")
                return
            try:
                link.send(command)
            except BoardError as error:
                # Asking again every tick would flood the board and the operator.
                self._end_mission(Outcome.REFUSED, f"stopped: the board refused {command}: {error}")
                return
        if mission.problem is not None:
            self._end_mission(Outcome.FAILED, f"stopped: {mission.problem}")
        elif mission.finished:
            self._end_mission(Outcome.DONE, "done", stop=False)

    def _speed_bound(self, state: MotorState | None) -> float | None:
        """How fast the robot (its wheels, turning on the spot) may be going when a move
        sent now starts: the speed just polled and what a tick at full acceleration
        adds. None when it is not known."""
        if state is None:
            return None
        style = self.teleop.board_r
        if style is not None and style <= 0:
            speed: float | None = rotation_wheel_speed(state, style)
        else:
            speed = state.speed
        if speed is None or not math.isfinite(speed):
            return None
        return abs(speed) + self.teleop.limits.accel * self.period

    def _start_mission(self, mission: Mission, ended: MissionEnded) -> None:
        if self._replayer is not None:
            why: str | None = "a playback is running"
        elif self.link is None:
            why = "no link to the board"
        else:
            # Any mission, not only those that steer by the pose: none is worth a robot
            # driving blind among people, and the way out is a metre driven by hand.
            why = self.feed.untrusted
        if why is not None:
            self.note(f"{mission.name} not started: {why}")
            end = MissionEnd(Outcome.NOT_STARTED, f"not started: {why}")
            self._tell(MissionChanged(mission.name, running=False, end=end))
            ended(end)
            return
        # A pose that jumped before this mission is the pose it starts from: a flag left
        # from then would end it at its first poll.
        self.feed.pose_jumped = None
        self._end_mission(Outcome.CANCELLED, "replaced")
        self.deadman.release()
        self._mission, self._mission_ended = mission, ended
        self._tell(MissionChanged(mission.name, running=True))
        self.note(f"{mission.name} started")

    def _end_mission(self, outcome: Outcome, why: str, stop: bool = True) -> None:
        """End the mission with `outcome`. A mission that ended itself (finished: DONE;
        a problem: FAILED) and judged how (a stall, an arrival) knows better than "done"
        or "stopped"; one the loop ends from outside (ESTOP, the operator, the link, a
        command refused) ends as the loop says, whatever it had judged."""
        mission, self._mission = self._mission, None
        if mission is None:
            return
        end = MissionEnd(outcome, why)
        if isinstance(mission, Judged):
            ended_itself = outcome in (Outcome.DONE, Outcome.FAILED)
            judged = mission.outcome if ended_itself else None
            end = MissionEnd(judged or outcome, why, mission.detail)
        # Told first: whoever says what runs must not see it gone and its end not yet
        # known while the stop is being sent.
        self._tell(MissionChanged(mission.name, running=False, end=end))
        if stop:
            self._stop_robot()
        self.note(f"{mission.name} {why}")
        # Dropped as it is called: a callback holds its mission, which must not outlive it.
        ended, self._mission_ended = self._mission_ended, lambda end: None
        ended(end)

    def _stop_robot(self) -> None:
        if self.link is not None and not stop_robot(self.link, self.teleop.board_settings):
            self.note("could not command a stop: check the robot")

    def _start_playback(self, playback: Playback, ended: Callable[[], None]) -> None:
        self._end_playback("playback replaced")
        self._end_mission(Outcome.CANCELLED, "stopped for playback")
        self.deadman.release()
        self._stop_robot()
        # Teleop's move, if any, was just stopped; it must not wait for it to end.
        self.teleop.halt()
        self._replayer = Replayer(playback)
        self._playback_ended = ended
        self.note(f"playing back {playback.name} ({playback.duration:.1f} s); nothing is sent "
                    "to the robot")  # fmt: skip

    def _end_playback(self, why: str) -> None:
        if self._replayer is not None:
            self._replayer = None
            # The robot may have been moved meanwhile: take a fresh poll before acting.
            self._state = None
            self.note(why)
            self._playback_ended()

    def _play(self, now: float) -> None:
        """A playback tick: typed jobs (a stop) still reach the robot, nothing else does."""
        assert self._replayer is not None
        if self.link is not None:
            try:
                self._run_jobs(self.link, stops_only=True)
            except LinkError as error:
                self.note(f"LINK LOST: {error}")
                self._drop_link()
            except BoardRebootedError as error:
                self._board_restarted(error)
        else:
            self._fail_jobs()
        if self._replayer.playback.finished(now):
            # Only once the last entries have been shown, on an earlier tick.
            self._end_playback("playback finished; live again")
        else:
            self._replayer.advance(now, self._tell)

    def _run_requests(self) -> None:
        while True:
            try:
                change = self._requests.get_nowait()
            except queue.Empty:
                return
            change()

    def _tell(self, event: LoopEvent) -> None:
        # A listener that fails must not keep the others from hearing; one the operator
        # depends on stops the robot (subscribe). Logged the first time and every 20th,
        # not twenty times a second.
        for listener, vital in self._listeners:
            try:
                listener(event)
            except Exception as error:
                failures = self._listener_failures[listener] = self._listener_failures[listener] + 1
                if failures % 20 == 1:
                    log.exception("control loop listener failed on %s (%d times)",
                                  type(event).__name__, failures)  # fmt: skip
                if vital:
                    self.emergency_stop(f"the operator can no longer be told what the "
                                        f"robot does ({type(error).__name__})")  # fmt: skip

    def _note_estop(self, state: MotorState) -> None:
        """Report ESTOP when it rises and when it clears, not on every tick."""
        if state.estop != self._estop:
            self._estop = state.estop
            self.note(
                "ESTOP raised by the board: driving stopped" if state.estop else "ESTOP cleared"
            )

    def _stop_now(self) -> None:
        """What `emergency_stop` asked for, before anything else: the robot is stopped
        from a fresh poll; then everything that drove is over, and nothing typed before
        the stop goes out after it."""
        with self._halt_lock:
            halt = self._halt
        assert halt is not None
        why, close = halt
        self.deadman.release()
        self.teleop.halt()
        if self.link is None:
            outcome = "no link to the board: it keeps its last target"
        elif stop_robot(self.link, self.teleop.board_settings):
            outcome = "robot commanded to stop"
        else:
            outcome = "could not command a stop: check the robot"
        self._end_mission(Outcome.HALTED, f"stopped: {why}", stop=False)
        self._end_playback(f"playback stopped: {why}")
        self._fail_jobs()
        self.note(f"{why}: {outcome}")
        with self._halt_lock:
            # A close asked for while this stop went out is not lost: done next tick.
            if self._halt is halt or (close and self._halt is not None):
                self._halt = None
        if close:
            self._running = False
            link, self.link = self.link, None
            if link is not None:
                link.close()
            self._closed.set()
            return
        self._state = None
        self._publish()

    def _crash(self) -> None:
        """A bug in a tick: stop the robot, then start again from a fresh connection."""
        self._crashes += 1
        if self._crashes == 1 or self._crashes % 20 == 0:
            self.note("internal error in the control loop; robot commanded to stop")
        if self.link is not None:
            stop_robot(self.link)
        # Whatever was driving is over: nothing starts moving again by itself.
        self._end_mission(Outcome.HALTED, "stopped: internal error", stop=False)
        self._end_playback("playback stopped: internal error")
        self._drop_link()

    def _board_restarted(self, error: BoardRebootedError) -> None:
        """The board restarted: its settings are back at power-up, which teleop's picture
        of them (what the guard checks by) must say; its odometers restarted from zero:
        keep the pose, take new references."""
        self.note(f"{error}; its settings are back at power-up")
        self.feed.rebooted()
        self.teleop.forget_board()
        self.deadman.release()

    def _run_jobs(self, link: BoardLink, stops_only: bool = False) -> None:
        # Those queued by now: a job that queues another (reads one at a time) lets the
        # loop tick first.
        for _ in range(self._jobs.qsize()):
            if self._halt is not None:  # stopping now: nothing typed goes out
                return
            try:
                job, done, stop = self._jobs.get_nowait()
            except queue.Empty:
                return
            if stops_only and not stop:
                done(GiraffError("not sent: playing back, nothing goes to the robot"))
                continue
            try:
                result: object = job(link)
            except LinkError:
                raise
            except BoardRebootedError:
                # Found by a typed command (jobs go before the tick's poll): the tick's
                # to deal with, as if its poll had found it (and to say), or the guard
                # would go on checking by settings the board no longer holds.
                raise
            except GiraffError as error:
                result = error
            done(result)

    def _watch(self, exchange: Exchange) -> None:
        """Keep teleop's picture of the board's settings true, whoever sends them, and
        the odometry told of every move and fed every read of bulk_data (on later boards
        a read resets imdl/imdr); then tell the listeners."""
        if exchange.kind == "set":
            # A twm carries several values: `set twm vg cdp vgr v p 0`.
            _, name, text = exchange.command.split(None, 2)
            # A set whose answer went wrong may or may not have been taken: unknown.
            self.teleop.board_set(name, text if exchange.error is None else None)
        # After teleop's picture: the feed asks it what the move just sent was.
        self.feed.watch(exchange, self.teleop.board_settings)
        self._tell(exchange)

    def _reconnect(self) -> bool:
        now = self.clock.now()
        if now < self._retry_at:
            return False
        try:
            link = self.connect()
            try:
                link.add_observer(self._watch)
                # Before anything else, the robot is told to stop (design.md); then
                # settings within the limits replace whatever the board holds; then the
                # board is asked what it is, which reads nothing that moves it.
                if not stop_robot(link):
                    raise LinkError("the board did not take the stop command")
                self.teleop.forget_board()
                for command in self.teleop.safe_settings():
                    link.send(command)
                features = probe(link)
            except GiraffError:
                link.close()
                raise
        except GiraffError as error:
            delay = BACKOFF_S[min(self._failures, len(BACKOFF_S) - 1)]
            self._failures += 1
            self._retry_at = now + delay
            if self._failures == 1 or self._failures % 10 == 0:
                self.note(f"cannot reach the board ({error}); retrying every {delay:g} s")
            return False
        # A board that greeted was powered up just now: its counters started again.
        self.feed.connected(features, powered_up=link.version is not None)
        self.gauges.connected(features)
        board = self.feed.describe()
        if self._failures:
            self.note(f"link restored; robot commanded to stop; {board}")
        else:
            self.note(f"connected to {link.port.port}, {board}")
        self._failures = 0
        self.link = link
        self._state = None
        return True

    def _drop_link(self) -> None:
        link, self.link = self.link, None
        self.feed.disconnected()
        self.gauges.disconnected()
        self.deadman.release()
        self.teleop.forget_board()
        self._state = None
        self._retry_at = self.clock.now()
        if link is not None:
            link.close()
        self._fail_jobs()

    def _fail_jobs(self) -> None:
        """Nothing typed while the link is down may reach the board when it comes back."""
        while True:
            try:
                _, done, _ = self._jobs.get_nowait()
            except queue.Empty:
                return
            done(LinkError("not sent: no link to the board"))

    def _publish(self) -> None:
        replayer, mission = self._replayer, self._mission
        telemetry = Telemetry(
            link=LinkState.CONNECTED if self.link else LinkState.LOST,
            state=replayer.state if replayer else self._state,
            pose=replayer.pose if replayer else self.localisation.pose,
            intent=self.deadman.held(),
            speed=self.teleop.speed,
            board_r=self.teleop.board_r,
            autopoll=self.autopoll,
            loop_hz=self._rate,
            late_ms=self._late * 1e3,
            playback=replayer.status(self.clock.now()) if replayer else None,
            mission=mission.progress if mission else None,
            battery=self.gauges.battery,
            stalk=self.gauges.stalk,
            board=self.feed.features,
            estimate=replayer.estimate if replayer else self.localisation.estimate(),
            blocked=self.teleop.blocked and not replayer,
        )
        self._tell(telemetry)
