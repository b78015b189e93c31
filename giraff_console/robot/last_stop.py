"""Every way the console can end reaches the control loop as "stop now" (design.md).

Signals. SIGHUP (the SSH connection dropped), SIGTERM and SIGINT are blocked on every
thread and taken by a thread of their own with `sigwait`, so that they act at once.
A Python signal handler runs on the main thread, and only when that thread gets to
it: on a loaded machine, with the screen being drawn, that took long enough for the
loop to renew `set p` for another 0.45 s after a SIGHUP (issue 12). The watcher tells
the loop to stop the robot and close the port, waits for that, asks the front end to
leave, and ends the process itself if it is still there soon after, so that a console
whose terminal has gone never holds the board's port.

Exceptions. One that escapes any thread (`threading.excepthook`), the main thread
(`sys.excepthook`) or the front end (which calls `crashed`) stops the robot before
anything else happens, and is then reported as usual.
"""

from __future__ import annotations

import logging
import os
import signal
import sys
import threading
from collections.abc import Callable
from types import TracebackType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    # Only for the type: the program's entry point imports SIGNALS from here before
    # anything that may start a thread (launch.py).
    from giraff_console.robot.control_loop import ControlLoop

log = logging.getLogger(__name__)

SIGNALS = frozenset({signal.SIGHUP, signal.SIGTERM, signal.SIGINT})
# Issue 12: gone within 2 s of SIGHUP or SIGTERM. The loop has STOP_TIMEOUT_S to stop the
# robot and close the port, the front end LEAVE_TIMEOUT_S to close; whatever happens
# meanwhile (a link stuck in a timeout), the process ends itself at EXIT_DEADLINE_S.
STOP_TIMEOUT_S = 1.0
LEAVE_TIMEOUT_S = 0.8
EXIT_DEADLINE_S = 1.9


class LastStop:
    """Stops the robot on every signal and unhandled exception of the process.

    `install` must run on the main thread before any other thread starts, so that
    every thread inherits the blocked signals (launch.py blocks them even before the
    imports). A signal that lands on a thread which does not block them all the same
    is handed on to the watcher by a handler, late but never lost.
    """

    def __init__(self, control: ControlLoop, leave: Callable[[str], None] = lambda why: None,
                 exit: Callable[[int], None] = os._exit,
                 signals: frozenset[signal.Signals] = SIGNALS) -> None:  # fmt: skip
        """`leave(why)` asks the front end to close (from the watcher's thread); `exit`
        ends the process if it has not left in time. `signals` are those that stop the
        robot: the daemon, which has no terminal to lose, leaves SIGHUP out."""
        self.control = control
        self.signals = signals
        self.leave = leave
        self.exit = exit
        self.signalled: signal.Signals | None = None
        self._watcher: threading.Thread | None = None
        self._disarmed = False
        self._restore: Callable[[], None] = lambda: None

    def install(self) -> None:
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
        self._watcher = threading.Thread(target=self._watch, name="last-stop", daemon=True)
        self._watcher.start()
        handlers = {signum: signal.signal(signum, self._hand_on) for signum in self.signals}
        hooks = threading.excepthook, sys.excepthook
        threading.excepthook = self._thread_crashed
        sys.excepthook = self._main_crashed

        def restore() -> None:
            threading.excepthook, sys.excepthook = hooks
            for signum, handler in handlers.items():
                signal.signal(signum, handler)
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)

        self._restore = restore

    def uninstall(self) -> None:
        """Undo `install` once what it guarded is over and the process goes on (the CLI
        called in-process, as tests do): the watcher ends, the rest is as it was."""
        watcher = self._watcher
        if watcher is not None and watcher.is_alive() and watcher.ident is not None:
            self._disarmed = True
            signal.pthread_kill(watcher.ident, signal.SIGTERM)  # taken by its sigwait
            watcher.join(STOP_TIMEOUT_S)
        self._restore()

    def crashed(self, error: BaseException) -> None:
        """An exception the front end did not handle: stop the robot first."""
        self.control.emergency_stop(f"internal error ({type(error).__name__})")

    # -- inside -------------------------------------------------------------------------

    def _watch(self) -> None:
        signum = signal.Signals(signal.sigwait(self.signals))
        if self._disarmed:
            return
        self.signalled = signum
        code = 128 + signum
        # Whatever happens below, the process is gone in time and lets go of the port.
        deadline = threading.Timer(EXIT_DEADLINE_S, self.exit, args=(code,))
        deadline.daemon = True
        deadline.start()
        self.control.emergency_stop(f"{signum.name} received", close=True)
        if not self.control.wait_closed(STOP_TIMEOUT_S):
            log.error("%s: the control loop did not stop the robot in time", signum.name)
            self.control.stop(f"{signum.name} received", timeout=0.0)
        if signum != signal.SIGHUP:
            # SIGHUP: the terminal is gone, and nothing can be drawn on it any more.
            self.leave(signum.name)
            threading.Event().wait(LEAVE_TIMEOUT_S)
        self.exit(code)

    def _hand_on(self, signum: int, frame: object) -> None:
        """A signal taken by a thread that did not block it: to the watcher with it."""
        watcher = self._watcher
        if watcher is not None and watcher.ident is not None:
            signal.pthread_kill(watcher.ident, signum)

    def _thread_crashed(self, args: threading.ExceptHookArgs) -> None:
        if args.exc_value is not None:
            self.crashed(args.exc_value)
        threading.__excepthook__(args)

    def _main_crashed(self, kind: type[BaseException], error: BaseException,
                      traceback: TracebackType | None) -> None:  # fmt: skip
        self.crashed(error)
        sys.__excepthook__(kind, error, traceback)
