"""A console's side of the socket: the robot service of a running daemon (issue 15).

`RemoteRobot` offers what the in-process RobotService offers a front end, `execute`
and `subscribe`, across the daemon's socket, so that the screen and the commands work
the same on either. A reading thread hands each event to the listeners and each answer
to the request waiting for it; a heartbeat tells the daemon the console is still there
between keys. When the daemon goes, the listeners are told so in a note, and every
request is answered "the daemon has gone" rather than waited on.
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import threading
import time
from pathlib import Path

from giraff_console.robot.loop_events import Note
from giraff_console.service import commands as c
from giraff_console.service.console_hello import Asked, Hello
from giraff_console.service.daemon import Answered, Welcome, daemon_alive
from giraff_console.service.events import Answered as Callback
from giraff_console.service.events import Reply, ServiceEvent, ServiceListener
from giraff_console.service.transport import Connection, ConnectionClosed, connect
from giraff_console.service.wire import WireError

log = logging.getLogger(__name__)

# Seconds to wait for the daemon's welcome, and for the answer to a request: planning a
# route on a large plan takes a few hundred milliseconds, a controller command up to 3 s.
WELCOME_TIMEOUT_S = 5.0
ANSWER_TIMEOUT_S = 10.0
# Seconds between heartbeats while nothing else is sent.
HEARTBEAT_S = 0.5
# Seconds a closed connection's daemon is given to let go of its lock, if it is dying.
GONE_WAIT_S = 0.5


class DaemonGone(Exception):
    """The daemon did not answer as a daemon should (or is not there)."""


class RemoteRobot:
    """The daemon's robot, attached as `console`; `take` asks for the controls if free."""

    def __init__(self, path: Path, console: str, *, take: bool = True) -> None:
        self._path = path
        self._connection: Connection = connect(path)
        self._listeners: tuple[ServiceListener, ...] = ()
        self._lock = threading.Lock()
        self._waiting: dict[int, Callback] = {}
        self._numbers = itertools.count(1)
        self._gone: str | None = None
        self._exit = threading.Event()
        try:
            self._connection.send(Hello(console, take))
            welcome = self._connection.receive(WELCOME_TIMEOUT_S)
        except (ConnectionClosed, WireError) as error:
            self._connection.close()
            raise DaemonGone(f"the daemon at {path} did not welcome us: {error}") from None
        if not isinstance(welcome, Welcome):
            self._connection.close()
            if isinstance(welcome, Answered) and not welcome.reply.ok:
                # Refused before the welcome: too many consoles, or no descriptors left.
                raise DaemonGone(f"the daemon at {path} {welcome.reply.text}")
            raise DaemonGone(f"the daemon at {path} did not welcome us")
        if welcome.over_limit is not None:
            # Welcomed only to ask a stop (stop_request.py does): a console is no use.
            self._connection.close()
            raise DaemonGone(f"the daemon at {path} has as many consoles attached as it "
                             f"takes ({welcome.over_limit}); `giraff-console stop` still "
                             "stops the robot")  # fmt: skip
        self.welcome = welcome
        self.console = welcome.console
        self._reader = threading.Thread(target=self._read, name="remote-reader", daemon=True)
        self._heart = threading.Thread(target=self._beat, name="remote-heartbeat", daemon=True)
        self._reader.start()
        self._heart.start()

    def subscribe(self, listener: ServiceListener, *, vital: bool = False) -> None:
        """Hear the daemon's events, on the reading thread. `vital` is the in-process
        service's (a failing screen stops the robot); here, a screen that fails hangs up,
        which lets go of the keys (the daemon's deadman)."""
        with self._lock:
            self._listeners += (listener,)

    def unsubscribe(self, listener: ServiceListener) -> None:
        with self._lock:
            self._listeners = tuple(other for other in self._listeners if other != listener)

    def post(self, request: c.Request, answered: Callback = lambda reply: None) -> None:
        """Ask the daemon without waiting: requests go in the order posted, and the
        daemon answers keys and stops at once, in that order; `answered` gets the reply
        on the reading thread."""
        if self._gone is not None:
            answered(Reply(False, self._gone))
            return
        number = next(self._numbers)
        with self._lock:
            self._waiting[number] = answered
        try:
            self._connection.send(Asked(number, request))
        except ConnectionClosed as error:
            self._hung_up(f"the daemon has gone ({error})")

    def execute(self, request: c.Request, timeout: float = ANSWER_TIMEOUT_S) -> Reply:
        """Ask the daemon and wait for its answer, at most `timeout` seconds."""
        done = threading.Event()
        replies: list[Reply] = []

        def answered(reply: Reply) -> None:
            replies.append(reply)
            done.set()

        self.post(request, answered)
        if not done.wait(timeout):
            return Reply(False, self._gone or f"no answer from the daemon in {timeout:g} s")
        return replies[0]

    def close(self) -> None:
        """Hang up: the daemon lets go of the keys this console held."""
        self._exit.set()
        self._connection.close()
        for thread in (self._reader, self._heart):
            if thread is not threading.current_thread():
                thread.join(2.0)

    @property
    def gone(self) -> str | None:
        """Why the daemon is no longer there, or None while it is."""
        return self._gone

    def _read(self) -> None:
        try:
            self._take_messages()
        except Exception:
            # A screen that cannot take what the daemon says hangs up, so that the
            # daemon lets go of the keys it held, rather than leave it driving blind.
            log.exception("a console's listener failed; hanging up")
            self._hung_up("this console failed; it has hung up")
            self._connection.close()

    def _take_messages(self) -> None:
        while not self._exit.is_set():
            try:
                message = self._connection.receive(0.2)
            except ConnectionClosed:
                self._hung_up(self._why_closed())
                return
            except WireError:
                continue  # one line garbled; the next may be whole
            if isinstance(message, Answered):
                with self._lock:
                    answered = self._waiting.pop(message.number, None)
                if answered is not None:
                    answered(message.reply)
            elif message is not None:
                self._tell(message)  # type: ignore[arg-type]

    def _why_closed(self) -> str:
        """What the end of the connection means for the robot, said only as it is: a
        daemon that died leaves the robot to stop within the reach it was last sent
        (robot/safety.py); one that only hung up on this console drives on with
        whatever it was doing."""
        # A daemon killed outright closes its sockets and lets go of its lock in the
        # same moment, not always in that order: a little time to tell which it was.
        deadline = time.monotonic() + GONE_WAIT_S
        alive = daemon_alive(self._path)
        while alive and time.monotonic() < deadline:
            time.sleep(0.02)
            alive = daemon_alive(self._path)
        if alive:
            return ("the daemon hung up on this console; it still runs, and the robot goes "
                    "on with what it was doing (`giraff-console status` says what; "
                    "`giraff-console stop` stops it)")  # fmt: skip
        return ("the daemon has gone: the robot comes to rest within the short distance "
                "it was last sent ahead")  # fmt: skip

    def _tell(self, event: ServiceEvent) -> None:
        for listener in self._listeners:
            listener(event)

    def _hung_up(self, why: str) -> None:
        if self._gone is not None or self._exit.is_set():
            return
        self._gone = why
        with self._lock:
            waiting, self._waiting = self._waiting, {}
        for answered in waiting.values():
            answered(Reply(False, why))
        with contextlib.suppress(Exception):  # the screen may be what failed
            self._tell(Note(why))

    def _beat(self) -> None:
        while not self._exit.wait(HEARTBEAT_S):
            if self._gone is not None:
                return
            try:
                self._connection.send(Asked(0, c.Heartbeat()))
            except ConnectionClosed:
                return
