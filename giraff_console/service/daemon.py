"""The daemon's side of the socket: consoles attach to the robot service (issue 15).

`giraff-console serve` owns the board and runs the control loop; consoles (the screen,
`status`, `go`, `stop` …) attach over a Unix socket in the user's runtime folder, owner
only, and nothing listens on the network (service/transport.py).

A console says who it is (`Hello`), and is then told everything the service says, and
answers to its requests, on the one connection. Each console has a thread that reads
its requests and one that writes to it: the control loop only drops events into the
console's outbox and never waits on a socket, so that a console that stops reading
cannot delay a tick (issue 15, item 6). Quick requests (a key, a stop) are answered on
the reading thread, in the order typed; the others (planning a route, a controller
command waiting for its reply) in a thread of their own, so a stop is never queued
behind them.

A console that hangs up, or whose connection dies, is detached: if it held the
controls its keys are let go of at once, and a mission it started carries on.

Only one daemon runs for a user: it holds a lock on a file beside its socket for as long
as it runs, so that two started at once cannot both take the socket (and the board).
"""

from __future__ import annotations

import contextlib
import fcntl
import logging
import os
import queue
import threading
from dataclasses import dataclass
from pathlib import Path

from giraff_console.camera.shared_frame import SharedFrame
from giraff_console.link import Exchange
from giraff_console.link.board_probe import BoardFeatures
from giraff_console.link.errors import LinkDisconnected, LinkError, LinkTimeout
from giraff_console.link.motor_state import MotorState
from giraff_console.missions.go_to import GoReport
from giraff_console.missions.patrol_report import PatrolReport, StopReport
from giraff_console.protocol.charger import ChargeStatus
from giraff_console.protocol.errors import (
    ArgumentError,
    BoardError,
    BoardRebootedError,
    CommandError,
    GiraffError,
    ProtocolError,
    QueueRolloverError,
    UnknownNameError,
)
from giraff_console.robot.battery import Battery
from giraff_console.robot.deadman import Intent
from giraff_console.robot.localisation import Estimate, PoseBasis
from giraff_console.robot.loop_events import MissionChanged, Note
from giraff_console.robot.mission import MissionEnd, Outcome, Progress
from giraff_console.robot.odometry import Pose
from giraff_console.robot.replay import PlaybackStatus
from giraff_console.robot.telemetry import LinkState, Telemetry
from giraff_console.service import commands as c
from giraff_console.service import wire
from giraff_console.service.events import (
    Answer,
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
    Situation,
)
from giraff_console.service.outbox import Outbox
from giraff_console.service.robot_service import RobotService
from giraff_console.service.transport import (
    Connection,
    ConnectionClosed,
    DaemonRunning,
    TransportError,
    accept,
    listen,
)
from giraff_console.service.wire import WireError

log = logging.getLogger(__name__)

# Seconds between looks at the exit event while waiting for a console or a request.
POLL_S = 0.2
# Answered on the reading thread at once, in the order typed: the keys, the stops and
# what waits on nothing.
URGENT = (c.Press, c.Halt, c.StopMission, c.Pause, c.Resume, c.Speed, c.Heartbeat,
          c.TakeControls, c.Status, c.Release, c.Shutdown, c.View)  # fmt: skip
# Seconds the first line (Hello) may take to come.
HELLO_TIMEOUT_S = 5.0


@dataclass(frozen=True)
class Hello:
    """A console's first message: who it is, and whether it wants the controls."""

    console: str
    take: bool = True


@dataclass(frozen=True)
class Welcome:
    """The daemon's first answer: the console's name as the others see it, the floor
    plan the robot drives by (for the map) and how things stand."""

    console: str
    floorplan: Path | None
    simulator: bool
    controls: Controls
    situation: Situation
    route: RouteShown | None


@dataclass(frozen=True)
class Asked:
    """A request, numbered so that its answer can be told apart."""

    number: int
    request: c.Request


@dataclass(frozen=True)
class Answered:
    number: int
    reply: Reply


class Daemon:
    """Serves `service` on a Unix socket at `path` until `stop`."""

    def __init__(self, service: RobotService, path: Path, floorplan: Path | None, *,
                 simulator: bool) -> None:  # fmt: skip
        """`floorplan` and `simulator` are what the consoles are told of the robot."""
        self.service = service
        self.path = path
        self.floorplan = floorplan
        self.simulator = simulator
        self._exit = threading.Event()
        self._lock = _lock_beside(path)
        try:
            self._listener = listen(path)
        except TransportError:
            os.close(self._lock)
            raise
        self._threads: list[threading.Thread] = []
        self._names: set[str] = set()
        self._names_lock = threading.Lock()

    def serve_forever(self) -> None:
        """Take consoles as they come, until `stop`."""
        try:
            while not self._exit.is_set():
                connection = accept(self._listener, POLL_S)
                if connection is None:
                    continue
                thread = threading.Thread(target=self._console, args=(connection,),
                                          name="daemon-console", daemon=True)  # fmt: skip
                self._threads = [t for t in self._threads if t.is_alive()] + [thread]
                thread.start()
        finally:
            self._close_listener()

    def stop(self) -> None:
        """Stop taking consoles and let the attached ones go (each is detached)."""
        self._exit.set()

    def join(self, timeout: float) -> None:
        for thread in self._threads:
            thread.join(timeout)

    def _close_listener(self) -> None:
        self._listener.close()
        with contextlib.suppress(FileNotFoundError):
            self.path.unlink()
        os.close(self._lock)

    # -- one console --------------------------------------------------------------------

    def _console(self, connection: Connection) -> None:
        try:
            hello = connection.receive(HELLO_TIMEOUT_S)
        except (ConnectionClosed, WireError):
            connection.close()
            return
        if not isinstance(hello, Hello):
            connection.close()
            return
        pid = connection.peer_pid()
        where = "this process" if pid == os.getpid() else f"pid {pid}"
        name = self._unique(f"{hello.console} ({where})")
        outbox = Outbox()
        writer = threading.Thread(target=self._write, args=(connection, outbox),
                                  name="daemon-writer", daemon=True)  # fmt: skip
        asked: queue.SimpleQueue[Asked | None] = queue.SimpleQueue()
        worker = threading.Thread(target=self._work, args=(asked, name, outbox),
                                  name="daemon-requests", daemon=True)  # fmt: skip
        service = self.service
        # The welcome first, with this console among the attached: what the service says
        # from then on follows it. `outbox.put` never waits (see the module's note).
        service.attach(name, take=hello.take)
        outbox.put(Welcome(name, self.floorplan, self.simulator, service.controls(),
                           service.situation(), service.route()))  # fmt: skip
        service.subscribe(outbox.put)
        writer.start()
        worker.start()
        try:
            self._read(connection, name, outbox, asked)
        finally:
            service.unsubscribe(outbox.put)
            service.detach(name)
            asked.put(None)
            worker.join(2.0)
            outbox.close()
            writer.join(2.0)
            connection.close()
            with self._names_lock:
                self._names.discard(name)

    def _read(self, connection: Connection, name: str, outbox: Outbox,
              asked: queue.SimpleQueue[Asked | None]) -> None:  # fmt: skip
        """The console's requests, until it hangs up, falls too far behind, or the
        daemon stops."""
        while not self._exit.is_set() and not outbox.closed:
            try:
                message = connection.receive(POLL_S)
            except ConnectionClosed:
                return
            except WireError as error:
                outbox.put(Answered(-1, Reply(False, f"not understood: {error}")))
                continue
            if message is None:
                continue
            if not isinstance(message, Asked) or not isinstance(message.request, c.Request):
                outbox.put(Answered(-1, Reply(False, "not understood: not a request")))
                continue
            if isinstance(message.request, URGENT):
                self._answer(message, name, outbox)
            else:
                asked.put(message)

    def _work(self, asked: queue.SimpleQueue[Asked | None], name: str, outbox: Outbox) -> None:
        while (message := asked.get()) is not None:
            self._answer(message, name, outbox)

    def _answer(self, asked: Asked, name: str, outbox: Outbox) -> None:
        if isinstance(asked.request, c.View):
            outbox.wants_frames = asked.request.on
        try:
            reply = self.service.execute(asked.request, name)
        except Exception as error:  # a bug must not end the console's connection
            log.exception("request %r failed", asked.request)
            reply = Reply(False, f"failed: {type(error).__name__}: {error}")
        outbox.put(Answered(asked.number, reply))
        if isinstance(asked.request, c.Shutdown):
            self.stop()

    def _write(self, connection: Connection, outbox: Outbox) -> None:
        try:
            while (message := outbox.take(POLL_S)) is not None or not outbox.closed:
                if message is not None:
                    connection.send(message)
        except ConnectionClosed:
            pass  # the reading thread sees the hang-up too and detaches the console
        except Exception:
            # A console that can no longer be told what the robot does is hung up on,
            # so that its keys are let go of, rather than left driving blind.
            log.exception("writing to a console failed; hanging up on it")
        finally:
            if outbox.overflowed:
                log.error("a console fell too far behind; hanging up on it")
            connection.close()

    def _unique(self, name: str) -> str:
        with self._names_lock:
            unique, n = name, 2
            while unique in self._names:
                unique, n = f"{name} #{n}", n + 1
            self._names.add(unique)
            return unique


def daemon_alive(path: Path) -> bool:
    """Whether a daemon serves the socket at `path` still: its lock is held (a daemon
    killed with -9 lets go of it with its last breath; a daemon that only hung up on a
    console keeps it)."""
    try:
        lock = os.open(path.with_suffix(".lock"), os.O_RDWR)
    except OSError:
        return False
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(lock)  # closing releases a lock this took
    return False


def _lock_beside(path: Path) -> int:
    """A lock held for the daemon's lifetime; DaemonRunning if another holds it."""
    lock = os.open(path.with_suffix(".lock"), os.O_RDWR | os.O_CREAT, 0o600)
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(lock)
        raise DaemonRunning(path) from None
    return lock


# What crosses the socket: the daemon's own messages, the requests, and everything the
# robot says (a snapshot and all it holds, an exchange with its errors, notes).
wire.register(
    Hello, Welcome, Asked, Answered, Reply, Sent, Answer, SendEnd, Controls, RouteShown,
    RoomRenamed, Situation, GoReported, GoReport, PatrolStopReported, StopReport,
    PatrolReported, PatrolReport, SharedFrame, MapDrawn, PlanChanged, *c.REQUESTS,
    Telemetry, LinkState, MotorState, Pose, Intent, PlaybackStatus, Progress, Battery,
    ChargeStatus, BoardFeatures, Estimate, PoseBasis, Exchange, Note, MissionChanged, MissionEnd,
    Outcome,
    GiraffError, CommandError, ProtocolError, BoardRebootedError, BoardError,
    UnknownNameError, QueueRolloverError, ArgumentError, LinkError, LinkTimeout,
    LinkDisconnected,
)  # fmt: skip
