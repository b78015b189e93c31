"""A console that stays with the robot's daemon across its restarts (issue 26).

A daemon stopped or restarted (a crash, an update, `systemctl restart`) used to leave an
attached console showing the last snapshot as if it were live, every key answered "the
daemon has gone", until the operator quit and started it again. `Reattaching` holds
the console's connection to the daemon and makes another when it goes: the screen is
told `Disconnected` at once (the connection's end is seen within a reading timeout, and
whether the daemon died within GONE_WAIT_S: service/remote.py), asks nothing
meanwhile, and is told `Attached` with the new daemon's welcome when one is back,
having asked for the controls as it did at the start.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

from giraff_console.service import commands as c
from giraff_console.service.daemon import Welcome
from giraff_console.service.events import Answered, Reply, ServiceEvent, ServiceListener
from giraff_console.service.remote import DaemonGone, RemoteRobot
from giraff_console.service.transport import TransportError

# Seconds between looks at whether the connection is still there, and between tries to
# attach again once it is not: DISCONNECTED shows within a second of the daemon going,
# and the console is back within a second of a daemon taking consoles again.
WATCH_S = 0.1
RETRY_S = 0.5


@dataclass(frozen=True)
class Disconnected:
    """The daemon has gone; `why` says so as the connection ended."""

    why: str


@dataclass(frozen=True)
class Attached:
    """Attached again to a daemon: its welcome (the floor plan, the controls, what runs)."""

    welcome: Welcome


class Reattaching:
    """A daemon's robot (events.Robot) that attaches again, with `attach`, whenever the
    connection goes. Requests made while there is none are refused at once."""

    def __init__(self, first: RemoteRobot, attach: Callable[[], RemoteRobot]) -> None:
        self._attach = attach
        self._robot: RemoteRobot | None = first
        self._last = first.welcome
        self._listeners: tuple[ServiceListener, ...] = ()
        self._lock = threading.Lock()
        self._exit = threading.Event()
        first.subscribe(self._tell)
        self._watcher = threading.Thread(target=self._watch, name="reattach", daemon=True)
        self._watcher.start()

    @property
    def welcome(self) -> Welcome:
        """The welcome of the daemon attached to last."""
        robot = self._robot
        return robot.welcome if robot is not None else self._last

    @property
    def console(self) -> str:
        return self.welcome.console

    @property
    def attached(self) -> bool:
        robot = self._robot
        return robot is not None and robot.gone is None

    def subscribe(self, listener: ServiceListener, *, vital: bool = False) -> None:
        with self._lock:
            self._listeners += (listener,)

    def unsubscribe(self, listener: ServiceListener) -> None:
        with self._lock:
            self._listeners = tuple(other for other in self._listeners if other != listener)

    def post(self, request: c.Request, answered: Answered = lambda reply: None) -> None:
        robot = self._robot
        if robot is None or robot.gone is not None:
            answered(Reply(False, "disconnected: waiting for the daemon to come back"))
            return
        robot.post(request, answered)

    def close(self) -> None:
        """Hang up, and attach no more (an attaching under way is let go of by the
        watcher as it ends)."""
        self._exit.set()
        self._watcher.join(2.0)
        robot, self._robot = self._robot, None
        if robot is not None:
            robot.close()

    def _tell(self, event: ServiceEvent | Disconnected | Attached) -> None:
        for listener in self._listeners:
            listener(event)  # type: ignore[arg-type]

    def _watch(self) -> None:
        while not self._exit.wait(WATCH_S):
            robot = self._robot
            if robot is None or robot.gone is None:
                continue
            self._robot = None
            # Told first: hanging up joins the connection's threads, which takes time.
            self._tell(Disconnected(robot.gone))
            robot.close()
            again = self._again()
            if again is None:
                return
            if self._exit.is_set():  # closed while it attached: not to be kept
                again.close()
                return
            again.subscribe(self._tell)
            self._robot, self._last = again, again.welcome
            self._tell(Attached(again.welcome))

    def _again(self) -> RemoteRobot | None:
        """A new connection once a daemon takes consoles again; None on close."""
        while not self._exit.wait(RETRY_S):
            try:
                return self._attach()
            except (TransportError, DaemonGone, OSError):
                continue
        return None
