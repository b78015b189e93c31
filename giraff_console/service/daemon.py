"""The daemon's side of the socket: consoles attach to the robot service (issues 15, 30).

`giraff-console serve` owns the board and runs the control loop; consoles (the screen,
`status`, `go`, `stop` …) attach over a Unix socket in the user's runtime folder, owner
only, and nothing listens on the network (service/transport.py).

A console says who it is (`Hello`), and is then told everything the service says, and
answers to its requests, on the one connection.

One thread, the event loop (`selectors`), holds the listening socket and every
console's, non-blocking, each with bounded buffers both ways (service/console_socket.py):
no console, slow, fast, huge or one of many, makes it wait, and a thousand idle ones are
a thousand file descriptors, not a thousand threads. The daemon hears the service once;
the control loop only hands each event over and wakes the event loop, which never makes
the loop wait (issue 15, item 6), and which encodes each message once and writes the same
bytes to every console it is for. Quick requests (a key, a stop) are answered there at
once, in the order typed; the ones that wait (planning a route, a controller command
waiting for the board's answer) go to a few worker threads, one at a time a console, so
that a stop is never queued behind them.

Bounds (issue 30): at most `max_consoles` attached; a connection beyond them is welcomed
"over the limit" (up to OVER_LIMIT of them, the oldest hung up on to make room for the
newest) and served one stop, so that `giraff-console stop`, itself a new connection,
is obeyed however many consoles there are; anything else it asks is refused ("too many
consoles") and it is hung up on. At most GREETING connections may be still to say Hello,
HELLO_TIMEOUT_S each, the oldest dropped first for the same reason: a `stop` is always the
newest. A daemon out of file descriptors refuses the newest connection with the one it
keeps spare, and goes on serving.

A console that hangs up, or whose connection dies, is detached: if it held the
controls its keys are let go of at once, and a mission it started carries on.

Only one daemon runs for a user: it holds a lock on a file beside its socket for as long
as it runs, so that two started at once cannot both take the socket (and the board).
"""

from __future__ import annotations

import collections
import contextlib
import errno
import fcntl
import logging
import os
import queue
import selectors
import socket
import threading
import time
from collections.abc import Callable
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
from giraff_console.service.console_hello import Asked, Hello
from giraff_console.service.console_socket import (
    REQUESTS_PER_S,
    WAITING,
    ConsoleSocket,
    Stage,
    StoppedReading,
)
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
from giraff_console.service.robot_service import RobotService
from giraff_console.service.transport import (
    ConnectionClosed,
    DaemonRunning,
    TransportError,
    encode_line,
    listen,
    parse,
    peer_pid,
)
from giraff_console.service.wire import WireError

log = logging.getLogger(__name__)

# Seconds between looks at the exit event, the greetings and the stuck writers.
POLL_S = 0.2
# Answered by the event loop at once, in the order typed: the keys, the stops and what
# waits on nothing.
URGENT = (c.Press, c.Halt, c.StopMission, c.Pause, c.Resume, c.Speed, c.Heartbeat,
          c.TakeControls, c.Status, c.Release, c.Shutdown, c.View)  # fmt: skip
# The operator's stops: never rate limited, and served over the connection limit.
STOPS = (c.Halt, c.StopMission, c.Shutdown)
# Seconds the first line (Hello) may take to come; and a console welcomed over the limit
# to ask for its stop.
HELLO_TIMEOUT_S = 5.0
# Consoles attached at once, unless told otherwise (`serve --max-consoles`).
MAX_CONSOLES = 64
# Connections still to say Hello, and connections over the limit waiting to ask a stop.
# Room for a burst of consoles connecting at once (each says Hello as it connects, but a
# loaded machine may take a while to run them), within the descriptors a process has.
GREETING = 128
OVER_LIMIT = 16
# Descriptors the daemon keeps besides its connections: the board, the lidar, the
# camera, the logs and a recording's files, the lock, the selector and its wake-up pair.
RESERVED_DESCRIPTORS = 64
# Threads that run the requests that wait.
WORKERS = 4
# Connections taken at one turn of the loop, and the characters of a console's name.
ACCEPT_BATCH = GREETING
NAME_CHARS = 80
# Seconds a connection told why it is refused has to take it before it is closed.
LEAVING_S = 1.0
# Lines kept made, for the consoles still to be sent them (about a second's events).
LINES_KEPT = 64
# Seconds the daemon, ending, gives its last answers to reach the consoles.
DRAIN_S = 1.0
# The interpreter's switch interval in the daemon: a thread that wants it waits at most
# about this long for another's pure-Python work (the control loop's tick, 50 ms, must
# not wait behind the event loop's; Python's default is 5 ms).
SWITCH_INTERVAL_S = 0.001
# What a console is told when it cannot be served: no Python text, ever (issue 30).
INTERNAL_ERROR = "refused: internal error, logged"
NO_DESCRIPTORS = "refused: the daemon has no file descriptors left; try again later"


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
    # The limit on consoles this one is over: not attached, it may ask one stop and is
    # then hung up on (Daemon's note); None for a console attached.
    over_limit: int | None = None


@dataclass(frozen=True)
class Answered:
    number: int
    reply: Reply


class Daemon:
    """Serves `service` on a Unix socket at `path` until `stop`."""

    def __init__(self, service: RobotService, path: Path, floorplan: Path | None, *,
                 simulator: bool, max_consoles: int = MAX_CONSOLES) -> None:  # fmt: skip
        """`floorplan` and `simulator` are what the consoles are told of the robot;
        `max_consoles`, how many may be attached at once."""
        if max_consoles < 1:
            raise ValueError(f"max_consoles must be at least 1, not {max_consoles}")
        self.service = service
        self.path = path
        self.floorplan = floorplan
        self.simulator = simulator
        self.max_consoles = max_consoles
        self._exit = threading.Event()
        self._lock = _lock_beside(path)
        try:
            self._listener = listen(path)
        except TransportError:
            os.close(self._lock)
            raise
        self._listener.setblocking(False)
        # The control loop's and the workers' way to wake the event loop: a byte.
        self._wake_in, self._wake_out = socket.socketpair()
        self._wake_in.setblocking(False)
        self._wake_out.setblocking(False)
        self._woken = False
        self._selector = selectors.DefaultSelector()
        self._selector.register(self._listener, selectors.EVENT_READ, None)
        self._selector.register(self._wake_in, selectors.EVENT_READ, None)
        # Every connection by stage; dicts keep their order, the oldest first.
        self._greeting: dict[ConsoleSocket, None] = {}
        self._over_limit: dict[ConsoleSocket, None] = {}
        self._attached: dict[ConsoleSocket, None] = {}
        self._leaving: dict[ConsoleSocket, None] = {}  # told why, and hung up on
        self._names: set[str] = set()
        # What the service said, for the event loop to hand on: the newest telemetry,
        # camera frame and map alone (as each outbox keeps them), everything else in order.
        self._heard: collections.deque[object] = collections.deque()
        self._newest: dict[type, object] = {}
        # Answers from the workers: (console, answer).
        self._answered: collections.deque[tuple[ConsoleSocket, Answered]] = collections.deque()
        self._work: queue.SimpleQueue[tuple[ConsoleSocket, Asked] | None] = queue.SimpleQueue()
        self._workers = [threading.Thread(target=self._worker, name=f"daemon-requests-{n}",
                                          daemon=True) for n in range(WORKERS)]  # fmt: skip
        # Each message's line, made once for all the consoles it goes to.
        self._lines: collections.OrderedDict[int, tuple[object, bytes]] = collections.OrderedDict()
        # A descriptor kept spare, given up to accept and refuse a connection when the
        # process has no other (EMFILE), rather than leave it in the backlog for ever.
        self._spare: int | None = _spare()
        self._out_of_descriptors_at = -float("inf")

    def serve_forever(self) -> None:
        """Take consoles as they come, until `stop`."""
        self.service.subscribe(self._hear)
        for worker in self._workers:
            worker.start()
        try:
            while not self._exit.is_set():
                try:
                    self._turn(POLL_S)
                except Exception:
                    # A bug here must not end every console and mission with the daemon:
                    # said, and the next turn served as before.
                    log.exception("the consoles' event loop failed a turn")
                    time.sleep(POLL_S)
            self._drain(time.monotonic() + DRAIN_S)
        finally:
            self.service.unsubscribe(self._hear)
            for console in [*self._greeting, *self._over_limit, *self._attached, *self._leaving]:
                self._hang_up(console)
            for _ in self._workers:
                self._work.put(None)
            self._close_listener()

    def stop(self) -> None:
        """Stop taking consoles and let the attached ones go (each is detached); from
        any thread."""
        self._exit.set()
        self._wake()

    def join(self, timeout: float) -> None:
        for worker in self._workers:
            if worker.is_alive():
                worker.join(timeout)

    def _close_listener(self) -> None:
        self._selector.close()
        self._listener.close()
        self._wake_in.close()
        self._wake_out.close()
        if self._spare is not None:
            os.close(self._spare)
        with contextlib.suppress(FileNotFoundError):
            self.path.unlink()
        os.close(self._lock)

    # -- from other threads: never waits ----------------------------------------------

    def _hear(self, event: object) -> None:
        """Everything the service says, on its thread (the control loop's, mostly)."""
        if isinstance(event, (Telemetry, SharedFrame, MapDrawn)):
            self._newest[type(event)] = event
        else:
            self._heard.append(event)
        self._wake()

    def _wake(self) -> None:
        # At most one byte on its way: cleared by the event loop once it has taken the
        # bytes and before it looks at what it was woken for, so that nothing added
        # after the look goes unseen (_turn).
        if not self._woken:
            self._woken = True
            with contextlib.suppress(OSError):  # full: it is awake already; closed: ended
                self._wake_out.send(b"\0")

    def _worker(self) -> None:
        while (job := self._work.get()) is not None:
            console, asked = job
            reply = self._execute(asked.request, console)
            self._answered.append((console, Answered(asked.number, reply)))
            self._wake()

    # -- the event loop ---------------------------------------------------------------

    def _turn(self, timeout: float) -> None:
        accepting = False
        for key, mask in self._selector.select(timeout):
            if key.fileobj is self._listener:
                accepting = True
            elif key.fileobj is self._wake_in:
                # Emptied first, then cleared: a byte sent in between must not be taken
                # with the flag left set, or no one would wake the loop again.
                with contextlib.suppress(OSError):
                    self._wake_in.recv(4096)
                self._woken = False
            else:
                console: ConsoleSocket = key.data
                if mask & selectors.EVENT_READ and not console.gone:
                    self._guarded(console, self._read)
                if mask & selectors.EVENT_WRITE and not console.gone:
                    self._guarded(console, self._flush)
        self._hand_on()
        if accepting:
            self._accept()
        self._expire(time.monotonic())

    def _drain(self, deadline: float) -> None:
        """The last answers (a Shutdown's) and notes to the consoles, until `deadline`."""
        self._hand_on()
        while time.monotonic() < deadline and any(
            console.unsent or console.outbox.pending for console in self._attached
        ):
            for key, mask in self._selector.select(min(POLL_S, deadline - time.monotonic())):
                if key.data is not None and mask & selectors.EVENT_WRITE and not key.data.gone:
                    self._guarded(key.data, self._flush)

    def _guarded(self, console: ConsoleSocket, handle: Callable[[ConsoleSocket], None]) -> None:
        """`handle(console)`; a console that has gone, or that a bug cannot serve, is hung
        up on, and the others are served as before."""
        if console.gone:
            return
        try:
            handle(console)
        except ConnectionClosed as why:
            if console.outbox.overflowed:
                log.error("a console fell too far behind; hanging up on it")
            elif isinstance(why, StoppedReading):
                log.error("a console stopped reading; hanging up on it")
            self._hang_up(console)
        except Exception:
            log.exception("serving a console failed; hanging up on it")
            self._hang_up(console)

    def _hand_on(self) -> None:
        """What the service said and the workers answered, into the consoles' outboxes,
        and written."""
        touched: set[ConsoleSocket] = set()
        while self._answered:
            console, answered = self._answered.popleft()
            console.working = False
            if not console.gone:
                console.outbox.put(answered)
                touched.add(console)
                self._next_work(console)
        heard = [self._heard.popleft() for _ in range(len(self._heard))]
        if sum(isinstance(event, Controls) for event in heard) > 1:
            # Each says who holds the controls and who is attached, all of it: of those
            # said at one turn (many consoles attaching at once) only the last is news.
            last = max(i for i, event in enumerate(heard) if isinstance(event, Controls))
            heard = [e for i, e in enumerate(heard) if i == last or not isinstance(e, Controls)]
        for kind in (Telemetry, SharedFrame, MapDrawn):
            newest = self._newest.pop(kind, None)
            if newest is not None:
                heard.append(newest)
        if heard:
            for console in self._attached:
                for event in heard:
                    console.outbox.put(event)
            touched.update(self._attached)
        for console in touched:
            if not console.gone:
                self._guarded(console, self._flush)

    def _flush(self, console: ConsoleSocket) -> None:
        """As much as the console's socket takes now, from its outbox; watched for
        writing while some waits."""
        now = time.monotonic()
        while console.wants_more and (message := console.outbox.take(0)) is not None:
            line = self._line(message)
            if line is not None:
                console.queue(line)
        if console.outbox.overflowed:
            raise ConnectionClosed("too far behind")
        console.write(now)
        if console.closing and not console.unsent and not console.outbox.pending:
            raise ConnectionClosed("told why")
        events = selectors.EVENT_READ | (selectors.EVENT_WRITE if console.unsent else 0)
        if self._selector.get_key(console).events != events:
            self._selector.modify(console, events, console)

    def _line(self, message: object) -> bytes | None:
        """The line that carries `message`, made once for every console it goes to."""
        made = self._lines.get(id(message))
        if made is not None and made[0] is message:
            return made[1]
        try:
            line = encode_line(message)
        except Exception:  # a message that cannot cross is a bug here, not the console's
            log.exception("cannot send a %s to the consoles", type(message).__name__)
            return None
        self._lines[id(message)] = (message, line)
        if len(self._lines) > LINES_KEPT:
            self._lines.popitem(last=False)
        return line

    def _accept(self) -> None:
        now = time.monotonic()
        for _ in range(ACCEPT_BATCH):
            try:
                client, _ = self._listener.accept()
            except (BlockingIOError, InterruptedError):
                return
            except ConnectionAbortedError:
                continue
            except OSError as error:
                if error.errno in (errno.EMFILE, errno.ENFILE) and self._make_room(now):
                    continue
                if error.errno in (errno.EMFILE, errno.ENFILE):
                    self._refuse_newest(now)
                else:  # ENOBUFS, ENOMEM: the machine's, for a moment; serve on
                    log.error("cannot take a console: %s", error.strerror or error)
                return
            console = ConsoleSocket(client, now)
            self._selector.register(console, selectors.EVENT_READ, console)
            self._greeting[console] = None
            # Heard at once, not after the rest of a burst is taken: a client that said
            # Hello as it connected (`giraff-console stop` says Hello and Halt in one
            # write) is served in this turn; one that has said nothing costs a recv.
            self._guarded(console, self._read)
            if len(self._greeting) > GREETING:
                # The oldest goes: a `stop` just connected says Hello at once.
                self._hang_up(next(iter(self._greeting)))

    def _make_room(self, now: float) -> bool:
        """Out of file descriptors: the oldest connection that is not a console (one
        still to say Hello, or told why it is refused) is hung up on, so that the newest
        (perhaps `giraff-console stop`) can be taken. False if there is none."""
        for stage in (self._leaving, self._greeting):
            if stage:
                self._note_out_of_descriptors(now)
                self._hang_up(next(iter(stage)))
                return True
        return False

    def _note_out_of_descriptors(self, now: float) -> None:
        if now - self._out_of_descriptors_at > 10.0:
            log.error("out of file descriptors: refusing new consoles until some leave")
        self._out_of_descriptors_at = now

    def _refuse_newest(self, now: float) -> None:
        """Out of file descriptors: the spare one is given up for a moment to take the
        newest connection off the backlog, tell it why, and close it."""
        self._note_out_of_descriptors(now)
        if self._spare is not None:
            os.close(self._spare)
            self._spare = None
        try:
            client, _ = self._listener.accept()
        except OSError:
            pass
        else:
            with client:
                client.setblocking(False)
                with contextlib.suppress(OSError):
                    client.send(encode_line(Answered(-1, Reply(False, NO_DESCRIPTORS))))
        self._spare = _spare()

    def _expire(self, now: float) -> None:
        """Hang up on connections that did not say Hello, or ask their stop, in time, and
        on consoles that stopped reading."""
        for console in self._oldest(self._greeting, now - HELLO_TIMEOUT_S):
            self._hang_up(console)
        for console in self._oldest(self._over_limit, now - HELLO_TIMEOUT_S):
            self._refuse(console, self._too_many())
        for console in self._oldest(self._leaving, now - LEAVING_S):
            self._hang_up(console)
        for console in list(self._attached):
            if console.unsent:
                self._guarded(console, lambda stuck: stuck.check_stuck(now))

    @staticmethod
    def _oldest(stage: dict[ConsoleSocket, None], before: float) -> list[ConsoleSocket]:
        """The connections of `stage` there since `before`, oldest first."""
        old = []
        for console in stage:
            if console.since > before:
                break
            old.append(console)
        return old

    # -- one console ------------------------------------------------------------------

    def _read(self, console: ConsoleSocket) -> None:
        console.read()
        while not console.gone and not console.closing:
            try:
                line = console.line()
            except WireError as error:
                if console.stage is Stage.GREETING:
                    self._hang_up(console)  # not a console: it did not even say Hello
                else:
                    self._tell(console, Answered(-1, Reply(False, f"not understood: {error}")))
                continue
            if line is None:
                return
            try:
                message = parse(line)
            except WireError as error:
                message = error
            except Exception:  # a bug in decoding: the console is told no more than that
                log.exception("decoding a console's line failed")
                message = WireError("internal error, logged")
            if console.stage is Stage.GREETING:
                self._greet(console, message)
            else:
                self._asked(console, message)

    def _greet(self, console: ConsoleSocket, hello: object) -> None:
        del self._greeting[console]
        if isinstance(hello, WireError):  # a Hello with a field wrong: told which, and gone
            self._refuse(console, f"not understood: {hello}")
            return
        if not isinstance(hello, Hello):
            self._hang_up(console)
            return
        pid = peer_pid(console.socket)
        where = "this process" if pid == os.getpid() else f"pid {pid}"
        # A name goes to every console each time the controls change hands: kept short.
        name = self._unique(f"{hello.console[:NAME_CHARS]} ({where})")
        console.name = name
        console.since = time.monotonic()
        over = len(self._attached) >= self.max_consoles
        if over:
            # Not attached, told nothing more, and served a stop alone (the module's note).
            console.stage = Stage.OVER_LIMIT
            self._over_limit[console] = None
        else:
            # The welcome first, with this console among the attached: what the service
            # says from then on follows it.
            console.stage = Stage.ATTACHED
            self._attached[console] = None
            self.service.attach(name, take=hello.take)
        self._tell(console, self._welcome(name, self.max_consoles if over else None))
        if over and len(self._over_limit) > OVER_LIMIT:
            self._refuse(next(iter(self._over_limit)), self._too_many())

    def _welcome(self, name: str, over_limit: int | None = None) -> Welcome:
        service = self.service
        return Welcome(name, self.floorplan, self.simulator, service.controls(),
                       service.situation(), service.route(), over_limit)  # fmt: skip

    def _asked(self, console: ConsoleSocket, message: object) -> None:
        if isinstance(message, WireError):
            self._tell(console, Answered(-1, Reply(False, f"not understood: {message}")))
            return
        if not isinstance(message, Asked) or not isinstance(message.request, c.Request) or (
                not isinstance(message.number, int)):  # fmt: skip
            self._tell(console, Answered(-1, Reply(False, "not understood: not a request")))
            return
        request = message.request
        if console.stage is Stage.OVER_LIMIT:
            if isinstance(request, STOPS):
                self._leave(console)
                self._answer(console, message)
            elif isinstance(request, c.Heartbeat):
                self._tell(console, Answered(message.number, Reply(True)))
            else:
                self._refuse(console, self._too_many(), message.number)
            return
        if not isinstance(request, STOPS) and not console.allowed(time.monotonic()):
            self._tell(console, Answered(message.number, Reply(
                False, f"refused: more than {REQUESTS_PER_S:g} requests a second")))  # fmt: skip
        elif isinstance(request, URGENT):
            self._answer(console, message)
        elif len(console.waiting) >= WAITING:
            self._tell(console, Answered(message.number, Reply(
                False, f"refused: {WAITING} requests of this console wait already")))  # fmt: skip
        else:
            console.waiting.append(message)
            self._next_work(console)

    def _answer(self, console: ConsoleSocket, asked: Asked) -> None:
        if isinstance(asked.request, c.View):
            console.outbox.wants_frames = asked.request.on
        self._tell(console, Answered(asked.number, self._execute(asked.request, console)))
        if isinstance(asked.request, c.Shutdown):
            self.stop()

    def _execute(self, request: c.Request, console: ConsoleSocket) -> Reply:
        try:
            return self.service.execute(request, console.name)
        except Exception:  # a bug must not end the console's connection, nor be shown it
            log.exception("request %r failed", request)
            return Reply(False, INTERNAL_ERROR)

    def _next_work(self, console: ConsoleSocket) -> None:
        """The console's next waiting request to a worker, once its last is answered."""
        if not console.working and console.waiting:
            console.working = True
            self._work.put((console, console.waiting.popleft()))

    def _tell(self, console: ConsoleSocket, message: object) -> None:
        console.outbox.put(message)
        self._guarded(console, self._flush)

    def _refuse(self, console: ConsoleSocket, why: str, number: int = -1) -> None:
        """Tell `console` why, then hang up on it once that has gone, LEAVING_S at most."""
        self._leave(console)
        self._tell(console, Answered(number, Reply(False, why)))

    def _leave(self, console: ConsoleSocket) -> None:
        """Hung up on once what it was told has gone, LEAVING_S at most."""
        self._over_limit.pop(console, None)
        console.closing = True
        console.since = time.monotonic()
        self._leaving[console] = None
        if len(self._leaving) > GREETING:
            self._hang_up(next(iter(self._leaving)))

    def _too_many(self) -> str:
        return (f"refused: too many consoles attached (limit {self.max_consoles}); "
                "`giraff-console stop` still stops the robot")  # fmt: skip

    def _hang_up(self, console: ConsoleSocket) -> None:
        if console.gone:
            return
        for stage in (self._greeting, self._over_limit, self._attached, self._leaving):
            stage.pop(console, None)
        console.waiting.clear()
        with contextlib.suppress(KeyError, ValueError):
            self._selector.unregister(console)
        attached = console.stage is Stage.ATTACHED
        console.close()
        self._names.discard(console.name)
        if attached:
            self.service.detach(console.name)

    def _unique(self, name: str) -> str:
        unique, n = name, 2
        while unique in self._names:
            unique, n = f"{name} #{n}", n + 1
        self._names.add(unique)
        return unique


def descriptors_for(max_consoles: int) -> int:
    """The file descriptors a daemon serving `max_consoles` may need at once: every
    stage of connection full (the leaving ones bounded as the greeting ones), and what
    it keeps open besides."""
    return max_consoles + OVER_LIMIT + 2 * GREETING + RESERVED_DESCRIPTORS


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


def _spare() -> int | None:
    """A descriptor to give up when there is no other (Daemon._refuse_newest)."""
    try:
        return os.open(os.devnull, os.O_RDONLY)
    except OSError:
        return None  # out already: taken again at the next refusal


# What crosses the socket: the daemon's own messages, the requests, and everything the
# robot says (a snapshot and all it holds, an exchange with its errors, notes).
wire.register(
    Welcome, Answered, Reply, Sent, Answer, SendEnd, Controls, RouteShown,
    RoomRenamed, Situation, GoReported, GoReport, PatrolStopReported, StopReport,
    PatrolReported, PatrolReport, SharedFrame, MapDrawn, PlanChanged,
    Telemetry, LinkState, MotorState, Pose, Intent, PlaybackStatus, Progress, Battery,
    ChargeStatus, BoardFeatures, Estimate, PoseBasis, Exchange, Note, MissionChanged, MissionEnd,
    Outcome,
    GiraffError, CommandError, ProtocolError, BoardRebootedError, BoardError,
    UnknownNameError, QueueRolloverError, ArgumentError, LinkError, LinkTimeout,
    LinkDisconnected,
)  # fmt: skip
