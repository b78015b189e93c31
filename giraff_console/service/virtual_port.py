"""A virtual motor port: another program drives the board through the daemon (§4.5).

The thesis's remote control software held the motor port alone, and §4.5 suggests "a
virtual motor controller port that both pieces of software can connect to", with the
software behind it routing commands and replies. `serve --virtual-port` gives another
program a pseudo-terminal that speaks the board's protocol (Appendix A.3): it greets
when the program opens it, as a board greets when the host raises its power line, and
answers each command line with the reply lines and the `OK >` prompt. Our own
`BoardLink` connects to it as to a board.

The port is a client of the robot service, built by the composition root
(runtime/robot.py) as a console is: while a program has it open, the program is
attached as PROGRAM, and a move of its own takes the controls if nobody holds them (and
the settings' `virtual_port` lets it drive); the consoles show it holding them, and a
console that takes them back stops its move. Every command goes through the control
loop, the one owner of the link (design.md): a read is forwarded to the board as a job
on the loop's thread and the board's reply is relayed; anything else first passes the
same guard as a typed command (robot/command_guard.py), on that thread, where the
board's settings are known for sure, after its values are brought within the limits
where that can only make a move shorter, slower or surer to stop (`clamp_command`: the
deployed drivers never read a set's reply and renew their targets, wire-facts). What is
refused gets an error line in the board's own style (`Error: ...`), so a driver sees a
board error rather than silence:

- While a mission runs, or the operator drives with the keys, the program may read but
  nothing else: `Error: refused: a mission is running; the virtual port may only read`.
  This is checked on the loop's thread just before the command would go out, so a
  mission that started meanwhile is not raced.
- The program's stop (`set p 0`, with the drivers' `set a 0` and `set v 0` before it,
  wire-facts "Stopping") stops a move of its own as the operator's stop does: the
  console's braking stop (robot/safety.py) rather than a `set p 0` the board would
  brake through and come back from (B.2); and gives the controls back.
- The drivers' settings of their stop and idle idioms (`set v 0`, `set vg 0`, `set vgr
  0`, `set r 50`; they send them at start-up, and one on every loop while idle,
  wire-facts "What the deployed drivers do") go to the board, guarded, when nobody else
  drives, as settings that apply from the next move. While a mission or the operator's
  keys drive, they (and `set p 0`) are answered as the board answers and change
  nothing, said once in the log: they never end the daemon's mission. They are kept,
  and go to the board, guarded, before the program's next command, so that the board
  holds what the program believes it does. `set a 0`, whose meaning on a board is not
  documented and which the guard refuses, is never sent: the program's next move is
  refused until it sets `a` again.
- The operator's stop always wins: it ends a mission and lets go of the keys, and from
  then on the program cannot start a move while a mission or the keys drive; the stop
  goes out as a job after the program's one command in flight, and the loop's
  emergency stop is taken before any job, whose queue it empties. A front end that
  wants the program kept still after a stop says so with `hold`.
- A program that hangs up after a move of its own has the robot stopped: its last
  `set p` would otherwise carry on (wire-facts).

Readings that later boards reset on each read are shared out between the daemon and the
program (shared_readings.py). Every reply comes within `reply_timeout`: a loop that does
not run the job, or a lost link, gives the program an error line, and the job, if it
has not started by then, is dropped rather than sent late.
"""

from __future__ import annotations

import contextlib
import logging
import os
import select
import termios
import threading
import time
import tty
from collections.abc import Callable

from giraff_console.link import DEFAULT_TIMEOUT_S, BoardLink, Exchange, LinkError
from giraff_console.protocol.codec import TWM, Command, encode_float, parse_command
from giraff_console.protocol.errors import (
    BoardError,
    BoardRebootedError,
    CommandError,
    GiraffError,
)
from giraff_console.protocol.framing import BANNER_PREFIX, COMMAND_END, LINE_END, PROMPT
from giraff_console.robot.command_guard import (
    BARE_COMMANDS,
    READINGS,
    SETTINGS,
    check_command,
    clamp_command,
)
from giraff_console.robot.realtime import run_promptly
from giraff_console.robot.safety import stop_robot
from giraff_console.robot.wheel_odometers import Reading, firmware_reading
from giraff_console.service.commands import PROGRAM
from giraff_console.service.events import Controls
from giraff_console.service.robot_service import RobotService
from giraff_console.service.shared_readings import SharedReadings

log = logging.getLogger(__name__)

# Time from the port being opened to the greeting: the opening program configures and
# flushes the port first (pyserial flushes its input when it opens), as for the
# simulator's pty (sim/pty_server.py).
BOOT_DELAY_S = 0.05
# The longest wait in one select, so that the exit event and the greeting are seen.
POLL_S = 0.05
# With no program on the port its leader side reports a hang-up on every poll; looked
# at this often instead.
IDLE_POLL_S = 0.02
# More than a job may need on the loop beyond the link's own timeouts: a tick to start.
REPLY_MARGIN_S = 0.5
# The program's lines are taken at most this often, about what a 115200-baud line
# carries for the shortest exchange (`get v` and its 18-character answer take 2.1 ms):
# the deployed drivers send at most five a loop at 25-40 Hz (wire-facts), 200 a second.
MIN_LINE_S = 0.003
# A board's line buffer: a longer line is refused whole, not run in part (as
# sim/line.py assumes; the guard refuses anything over 64 characters anyway).
MAX_LINE_BYTES = 256

# The drivers' stop and idle idioms, as (setting, value): from a program that is not
# driving they are answered and change nothing (wire-facts "What the deployed drivers do").
IDLE_IDIOMS = frozenset({("p", 0.0), ("v", 0.0), ("a", 0.0), ("vg", 0.0), ("vgr", 0.0),
                         ("r", 50.0)})  # fmt: skip
NOT_DRIVING = (
    "while others drive, the program on the virtual port's stops and idle settings "
    "(set v 0, set p 0, set r 50, ...) are answered and change nothing; its settings go "
    "to the board before its next command"
)
# Settings a driver sets once and counts on (one sets `mode 2` only at start-up,
# wire-facts), which others change (missions, the keys and the braking stop send `mode
# 0`): the program's own go back to the board, guarded, before its next command.
BELIEVED = ("mode", "a", "cdp")
# Seconds after its last move at which a program that holds the controls and has gone
# quiet gives them back: its last target (within the reach) has long been reached.
QUIET_S = 5.0
OPERATOR_STOPPED = (
    "the operator stopped the robot; `release` in a console lets the program move it again"
)
ONLY_READS = "the virtual port may only read"
READS_ONLY = f'refused: the settings say virtual_port = "reads"; {ONLY_READS}'
MISSION_RUNNING = f"refused: a mission is running; {ONLY_READS}"
OPERATOR_DRIVING = f"refused: the operator is driving; {ONLY_READS}"
PLAYING_BACK = f"refused: a session is being played back; {ONLY_READS}"
ZEROED = "refused: {names} set to 0 to stop the robot; set {them} again before a move"
# The board's own answers to lines it cannot run (sim/board.py, wire-facts "Errors").
NOT_OPTIONAL = "Error: Argument wasn't optional"
UNKNOWN_ARGUMENT = "Error: Unknown argument"
LINE_TOO_LONG = "Error: Line too long"

Lines = list[str]


class VirtualPort:
    """A board-like pseudo-terminal for one program at a time, a client of `service`
    as a console is: the program attaches as PROGRAM while it has the port open, and may
    drive when it holds the controls (it takes them when nobody holds them). Its commands
    run as jobs on the service's control loop, the one owner of the link.

    `link_timeout` is the `[link] timeout` the loop's link waits for each reply; a reply
    to the program comes within twice that and REPLY_MARGIN_S (a resync and the
    command), or an error line does.
    """

    def __init__(self, service: RobotService, *, link_timeout: float = DEFAULT_TIMEOUT_S,
                 drives: bool = True) -> None:  # fmt: skip
        """`drives`: whether the program may take the controls and drive (the settings'
        `virtual_port`), or only read."""
        self.service = service
        self.drives = drives
        self.control = service.control
        # The operator's stop wins (§4.5): the program may not move the robot again until
        # a console says `release`.
        service.on_stop.append(lambda: self.hold(OPERATOR_STOPPED))
        service.on_release.append(lambda: self.hold(None))
        self.reply_timeout = 2 * link_timeout + REPLY_MARGIN_S
        self.shared = SharedReadings(self._increments)
        self._leader, follower = os.openpty()
        # Raw mode, set once on our side: no echo and no CR/LF translation for whoever
        # opens the port, even a program that does not configure it.
        tty.setraw(follower)
        self.path = os.ttyname(follower)
        os.close(follower)
        # Never block on a program that stops reading; hold its bytes back instead.
        os.set_blocking(self._leader, False)
        self._exit = threading.Event()
        self._thread: threading.Thread | None = None
        self._held: str | None = None
        self._connected = False
        self._greet_at: float | None = None
        self._partial = bytearray()
        self._overflow = False
        self._unsent = bytearray()
        # Settings the program zeroed to stop that the board still holds (`a`).
        self._zeroed: set[str] = set()
        # Idle settings the program sent while others drove, and the settings it counts
        # on (BELIEVED), for the board before its next command (the loop's thread).
        self._pending: dict[str, Command] = {}
        self._believed: dict[str, Command] = {}
        # Whether the program held the controls at the service's last word of them, and
        # when it last moved (time.monotonic()).
        self._holding = False
        self._last_move = 0.0
        # Whether a move of the program's is under way: stopped if it hangs up.
        self._moved = False
        # When the program's last line was taken (time.monotonic()).
        self._last_line = 0.0
        # Whether the log has said, since the program came, that its idle idioms do nothing.
        self._idle_noted = False

    # -- from other threads -------------------------------------------------------------

    def start(self) -> None:
        """Tap the loop's exchanges and serve the port on a thread of its own."""
        self.control.subscribe(self.shared.tap)
        self.service.subscribe(self._heard)
        self._thread = threading.Thread(target=self._run, name="virtual-port", daemon=True)
        self._thread.start()
        if self._thread.native_id is not None:
            # The board's stand-in answers as promptly as the loop it waits on runs
            # (robot/realtime.py): it sleeps in select between lines.
            log.info("virtual port: %s", run_promptly(self._thread.native_id))

    def close(self, timeout: float = 5.0) -> bool:
        """Stop serving and close the port: the program then reads EOF or EIO. True if
        the thread ended within `timeout` seconds."""
        self._exit.set()
        thread = self._thread
        if thread is not None:
            thread.join(timeout)
        self.control.unsubscribe(self.shared.tap)
        self.service.unsubscribe(self._heard)
        if self._connected:
            self.service.detach(PROGRAM)
        ended = thread is None or not thread.is_alive()
        if ended and self._leader >= 0:
            leader, self._leader = self._leader, -1
            with contextlib.suppress(OSError):
                os.close(leader)
        elif not ended:
            log.error("the virtual port's thread did not end within %g s", timeout)
        return ended

    def hold(self, why: str | None) -> None:
        """Refuse the program's moves with `why` from now on (the operator stopped the
        robot, say), or, with None, no longer. Reads and stops are always taken."""
        self._held = None if why is None else f"refused: {why}"

    def _heard(self, event: object) -> None:
        """The controls taken from the program: a move of its own is stopped, unless a
        mission or the keys drive now (they brake it themselves). Decided by whether it
        held them, not by whether it moved yet: a move may be on its way to the board as
        the controls are taken, and the stop is queued after it."""
        if not isinstance(event, Controls):
            return
        held, self._holding = self._holding, event.holder == PROGRAM
        if held and not self._holding:
            self.control.submit(self._stop_left_move, _log_failure, stop=True)

    def __enter__(self) -> VirtualPort:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- the port's thread --------------------------------------------------------------

    def _run(self) -> None:
        hangup = select.poll()
        hangup.register(self._leader, select.POLLIN)
        while not self._exit.is_set():
            timeout = POLL_S
            if self._greet_at is not None:
                timeout = max(0.0, min(timeout, self._greet_at - time.monotonic()))
            writing = [self._leader] if self._unsent else []
            try:
                readable, _, _ = select.select([self._leader], writing, [], timeout)
            except OSError:
                return  # the port was closed under us
            events = hangup.poll(0)
            if events and events[0][1] & select.POLLHUP and not events[0][1] & select.POLLIN:
                self._hang_up()
                self._exit.wait(IDLE_POLL_S)
                continue
            if not self._connected:
                self._connected = True
                self._greet_at = time.monotonic() + BOOT_DELAY_S
                # A console that does not take the controls until it drives.
                self.service.attach(PROGRAM, take=False)
            if readable:
                try:
                    data = os.read(self._leader, 4096)
                except (BlockingIOError, InterruptedError):
                    data = b""
                except OSError:
                    self._hang_up()
                    continue
                if data and self._greet_at is not None:
                    self._greet()  # a program that did not wait: greeted first
                self._receive(data)
            if self._greet_at is not None and time.monotonic() >= self._greet_at:
                self._greet()
            if self._holding and time.monotonic() - self._last_move > QUIET_S:
                # Gone quiet: the controls are free for a console or a mission.
                self.service.let_go(PROGRAM)
            if self._unsent:
                self._send()

    def _greet(self) -> None:
        """What a board prints as it powers up (A.3): its banner and the prompt. The
        banner is the real board's, when it greeted the console."""
        self._greet_at = None
        link = self.control.link
        version = link.version if link is not None else None
        self._unsent += _line(f"{BANNER_PREFIX} {version or 'version unknown (virtual port)'}")
        self._unsent += _line(PROMPT)
        # To the program the board just powered up: its odometers start from zero.
        self.shared.forget()
        self._zeroed.clear()
        self._pending.clear()
        self._believed.clear()
        self._idle_noted = False

    def _receive(self, data: bytes) -> None:
        """Bytes from the program: every line its CR ends is answered in turn."""
        for byte in data:
            if byte == COMMAND_END[0]:
                line, overflow = self._partial.decode("ascii", "replace"), self._overflow
                self._partial.clear()
                self._overflow = False
                # No faster than a board's line could carry them: a program that floods
                # the port must not have the loop (at real-time priority) tick for each.
                self._exit.wait(max(0.0, self._last_line + MIN_LINE_S - time.monotonic()))
                self._last_line = time.monotonic()
                replies = [LINE_TOO_LONG] if overflow else self._answer(line)
                for reply in [*replies, PROMPT]:
                    self._unsent += _line(reply)
                self._send()
                if self._exit.is_set():
                    return
            elif byte == LINE_END[-1]:
                continue  # a stray LF (a program sending CR LF) is no command
            elif len(self._partial) < MAX_LINE_BYTES:
                self._partial.append(byte)
            else:
                self._overflow = True

    def _send(self) -> None:
        try:
            written = os.write(self._leader, self._unsent)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            self._hang_up()
            return
        del self._unsent[:written]

    def _hang_up(self) -> None:
        """The program went away: forget its traffic; stop a move it left running."""
        if not self._connected:
            return
        self._connected = False
        self._greet_at = None
        self._unsent.clear()
        self._partial.clear()
        self._overflow = False
        with contextlib.suppress(termios.error):
            termios.tcflush(self._leader, termios.TCIOFLUSH)
        if self._moved:
            self._moved = False
            self.control.submit(self._stop_left_move, _log_failure, stop=True)
        self.service.detach(PROGRAM)

    # -- answering ----------------------------------------------------------------------

    def _answer(self, text: str) -> Lines:
        """The reply lines, the prompt not included, to one line from the program."""
        words = text.split()
        if not words:
            return []  # the board answers an empty line with its prompt alone
        try:
            command = parse_command(text.strip())
        except CommandError:
            return [_malformed(words)]
        if command.kind == "get":
            try:
                check_command(command, self.control.teleop.limits, {})
            except CommandError as error:
                if command.name not in READINGS:
                    # The board's own answer, which drivers rely on: our link's resync
                    # asks for a name that cannot exist and waits for exactly this.
                    return [f"Unknown name: {command.name}"]
                return [_error(f"refused: {error}")]
            return self._run_job(self._read(command))
        idiom = (
            command.kind == "set"
            and len(command.values) == 1
            and ((command.name, float(command.values[0])) in IDLE_IDIOMS)
        )
        if idiom:
            return self._stop_or_idle(command)
        known = SETTINGS if command.kind == "set" else BARE_COMMANDS
        if command.name not in known:
            return [f"Unknown name: {command.name}"]  # as the board answers (sim/board.py)
        return self._run_job(self._drive(command))

    def _read(self, command: Command) -> Callable[[BoardLink], Lines]:
        def read(link: BoardLink) -> Lines:
            with self.shared.own_read():
                exchange = link.send(command)
            return list(self.shared.share(exchange))

        return read

    def _drive(self, command: Command) -> Callable[[BoardLink], Lines]:
        """A set or a bare command: on the loop's thread, what may not go out is refused
        there, where nothing can change between the check and the command."""

        def drive(link: BoardLink) -> Lines:
            refused = self._only_reads()
            moves = command.kind == "set" and command.name in ("p", TWM)
            if moves:
                # Before the controls are taken: the quiet check must not see them held
                # by a program that has not moved yet.
                self._last_move = time.monotonic()
            if refused is None and moves:
                # A move needs the controls, taken if nobody holds them; a setting only
                # that nobody else drives.
                refused = (READS_ONLY if not self.drives else self.service.may_move(PROGRAM)
                           or self._held or _zeroed_message(self._zeroed))  # fmt: skip
            if refused is not None:
                return [_error(refused)]
            refused = self._send_pending(link) or self._send_believed(link)
            if refused is not None:
                return [_error(refused)]
            # The drivers never read a set's reply (wire-facts): what can be made safe
            # by bringing it within the limits is, and goes; the rest is refused.
            teleop = self.control.teleop
            clamped = clamp_command(command, teleop.limits, teleop.board_settings)
            exchange = self._send_guarded(link, clamped)
            if isinstance(exchange, str):
                return [_error(exchange)]
            self._zeroed -= set(clamped.settings)
            self._moved = self._moved or moves
            if clamped.kind == "set" and clamped.name in BELIEVED:
                self._believed[clamped.name] = clamped
            return list(exchange.lines)

        return drive

    def _send_guarded(self, link: BoardLink, command: Command) -> Exchange | str:
        """`command` through the guard to the board (the loop's thread); why not, if not."""
        teleop = self.control.teleop
        try:
            check_command(command, teleop.limits, teleop.board_settings)
        except CommandError as error:
            return f"refused: {error}"
        return link.send(command)

    def _send_pending(self, link: BoardLink) -> str | None:
        """The idle settings kept while others drove, to the board before the program's
        next command (the loop's thread); why the command may not go, if one is refused."""
        while self._pending:
            name, command = next(iter(self._pending.items()))
            sent = self._send_guarded(link, command)
            if isinstance(sent, str):
                return f"{sent} (the {command} this program sent before)"
            del self._pending[name]
        return None

    def _send_believed(self, link: BoardLink) -> str | None:
        """The settings the program counts on (BELIEVED) that the board no longer holds,
        back to it before the program's next command (the loop's thread); why that
        command may not go, if one is refused."""
        held = self.control.teleop.board_settings
        for name, command in list(self._believed.items()):
            if held.get(name) != command.settings[name]:
                sent = self._send_guarded(link, command)
                if isinstance(sent, str):
                    return f"{sent} (the {command} this program sent before)"
        return None

    def _only_reads(self) -> str | None:
        """Why the program may only read now, if it may (the loop's thread)."""
        control = self.control
        if control.playback is not None:
            return PLAYING_BACK
        if control.mission is not None:
            return MISSION_RUNNING
        if control.deadman.held() is not None or control.teleop.active:
            return OPERATOR_DRIVING
        return None

    def _stop_or_idle(self, command: Command) -> Lines:
        """A driver's stop or idle idiom. Decided on the loop's thread, where a mission
        or the keys cannot start between the check and what is done: a move of the
        program's own is stopped with the console's braking stop; with nobody else
        driving, an idle setting goes to the board, guarded; while others drive, it is
        answered as the board answers and kept for before the program's next command,
        as it is during a move of the program's own (the drivers' stop sets v 0 first)."""
        name = command.name

        def stop_or_idle(link: BoardLink) -> Lines:
            others = self._only_reads()
            if name == "p":
                if not (self._moved and others is None):
                    return [_echo(command)]  # no move of its own to stop
                self._moved = False
                if not self._brake(link):
                    return [_error("could not command a stop: check the robot")]
                # It no longer drives: the controls are free for a console or a mission.
                self.service.let_go(PROGRAM)
                return [_echo(command)]
            if name == "a":
                # Never sent (undocumented, refused by the guard): it sets a again first.
                self._zeroed.add("a")
                return [_echo(command)]
            if others is None and not self._moved:
                # A setting, as on a board: it applies from the next move (`set v 0` with
                # `vg` in mode 2 is a turn on the spot, wire-facts).
                sent = self._send_guarded(link, command)
                return [_error(sent)] if isinstance(sent, str) else list(sent.lines)
            # Kept for before the program's next command: while others drive, and while
            # a move of its own runs, whose stop (`set p 0` after it, wire-facts
            # "Stopping") brakes within the board's settings as they are: a board left
            # at v = 0 would run the move out instead (issue 30).
            self._pending[name] = command
            if others is not None and not self._idle_noted:
                self._idle_noted = True
                self.control.note(NOT_DRIVING)
            return [_echo(command)]

        # Run even during a playback (a stop is, the operator's too), to be answered.
        return self._run_job(stop_or_idle, stop=True)

    def _stop_left_move(self, link: BoardLink) -> None:
        """The program hung up, or lost the controls, after a move of its own: stop it,
        unless the operator or a mission drives now."""
        self._moved = False
        if self._only_reads() is None:
            self._brake(link)

    def _brake(self, link: BoardLink) -> bool:
        """The console's braking stop (robot/safety.py); the settings it changes for the
        stop (mode, a, cdp) go back as the program left them before its next command
        (`_send_believed`). True if it worked."""
        return stop_robot(link, self.control.teleop.board_settings)

    def _run_job(self, job: Callable[[BoardLink], Lines], stop: bool = False) -> Lines:
        """Run `job` on the loop's thread and wait for its lines, within reply_timeout."""
        request = _Request()

        def claimed(link: BoardLink) -> Lines | None:
            if not request.claim():
                return None  # given up on: nothing goes out late
            try:
                return job(link)
            except (LinkError, BoardRebootedError) as error:
                # The loop drops the link, or forgets the board's settings, and never
                # calls `done` for this job: the program is told now.
                request.finish(error)
                raise
            except GiraffError:
                raise  # the board's answer: the loop gives it to `done`
            except Exception:
                # A failure of the console's own: the loop logs it and stops the robot.
                request.finish(GiraffError("the console failed (logged)"))
                raise

        self.control.submit(claimed, request.finish, stop=stop)
        return request.wait(self.reply_timeout, self._exit)

    def _increments(self) -> bool:
        """Whether the board's `imdl`/`imdr` are increments now (the loop's thread): as
        the odometry reads them once its check against cdis decided, or as the firmware
        gives them while the odometry reads the encoders."""
        reading = self.control.odometry.reading
        if reading is Reading.ENCODERS:
            board = self.control.board
            return board is not None and firmware_reading(board) is Reading.INCREMENTS
        return reading is Reading.INCREMENTS


class _Request:
    """One command's way through the loop: claimed by the job as it starts, or given
    up on by the port when the reply is late; never both."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._state = "waiting"
        self._done = threading.Event()
        self._result: object = None

    def claim(self) -> bool:
        with self._lock:
            if self._state != "waiting":
                return False
            self._state = "running"
            return True

    def finish(self, result: object) -> None:
        """The job's lines, or the GiraffError it (or the loop, failing it) gave."""
        if self._done.is_set():
            return
        self._result = result
        self._done.set()

    def wait(self, timeout: float, exit_event: threading.Event) -> Lines:
        deadline = time.monotonic() + timeout
        while not self._done.wait(min(POLL_S, max(0.0, deadline - time.monotonic()))):
            if exit_event.is_set() or time.monotonic() >= deadline:
                with self._lock:
                    running = self._state == "running"
                    self._state = "abandoned"
                if running:  # it went out, or is going: its outcome is not known
                    return [_error(f"no answer from the board within {timeout:g} s")]
                return [_error(f"no answer from the control loop within {timeout:g} s; "
                               "nothing was sent")]  # fmt: skip
        result = self._result
        if isinstance(result, BoardError):
            return [result.line]  # the board's own error line, relayed
        if isinstance(result, GiraffError):
            return [_error(str(result))]
        if isinstance(result, list):
            return [str(line) for line in result]
        return [_error("no answer from the control loop")]


def _malformed(words: list[str]) -> str:
    """The board's own answer to a line that is no command it takes (sim/board.py)."""
    if words[0].lower() in ("set", "get") and len(words) < 2:
        return NOT_OPTIONAL
    return UNKNOWN_ARGUMENT


def _zeroed_message(zeroed: set[str]) -> str | None:
    if not zeroed:
        return None
    names = " and ".join(sorted(zeroed))
    return ZEROED.format(names=f"{names} {'were' if len(zeroed) > 1 else 'was'}", them=names)


def _echo(command: Command) -> str:
    """What a board answers to a set of one value (the value, as it encodes it; the
    link, and the drivers, take a set answered with or without it, wire-facts)."""
    return encode_float(float(command.values[0]))


def _error(text: str) -> str:
    """An error line in the board's style: a driver takes it as a board error."""
    return f"Error: {text}"


def _line(text: str) -> bytes:
    return text.encode("ascii", "replace") + LINE_END


def _log_failure(result: object) -> None:
    if isinstance(result, GiraffError):
        log.warning("virtual port: could not stop the move the program left: %s", result)
