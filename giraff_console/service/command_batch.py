"""Controller commands asked for together (c.SendCommands), checked and sent as one job
on the control loop's thread, and waited for.

`giraff-console send` has always kept one rule: every command is checked by the one
guard (robot/command_guard.py, with teleop's limits) against the board's settings as
the commands before it leave them, and if one is refused, none is sent. That holds only
where the board's settings are known for sure: on the loop's thread, which sees every
command that reaches the board (teleop.board_settings), in one job, so that nothing
else is sent between the check and the last command. The loop is held for the batch,
which is why it is short (c.MAX_COMMANDS).

Whoever asks waits for the answers, never for ever:

- the loop takes the job within TAKE_WAIT_S, or the asker gives it up and is told that
  nothing was sent; a job given up sends nothing when the loop comes to it, so that no
  command goes out after its asker was told it did not;
- once taken, the batch has COMMAND_WAIT_S a command; the link's own timeout (the
  settings' `timeout`, a second) ends a command the board does not answer well before
  that, as a lost link.

A lost link, and a board found to have restarted, are passed on to the loop after the
answers are kept: it drops the link, or forgets the board's settings, as for any
command (ControlLoop._run_jobs). So is a failure of the console's own, once the asker
is told.

An operator's stop wins over a batch: it is looked for before each command, and what
is left is not sent (SendEnd.STOPPED); the loop's stop then goes out. A batch of reads
alone holds the loop for one read at a time, a job each, so that the loop ticks
between them and a mission steers on.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence

from giraff_console.link import BoardLink, LinkError
from giraff_console.protocol import BoardRebootedError, Command, CommandError, GiraffError
from giraff_console.robot.command_guard import check_command
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.service.events import Answer, SendEnd, Sent

# Seconds the loop has to take the batch (it runs jobs at its next tick, 50 ms away).
TAKE_WAIT_S = 5.0
# Seconds a command taken may take to be answered, at most.
COMMAND_WAIT_S = 3.0


class CommandBatch:
    """`commands`, to be checked and sent by `control`'s loop (`send`)."""

    def __init__(self, commands: Sequence[Command], control: ControlLoop,
                 stopped: Callable[[], bool] = lambda: False) -> None:  # fmt: skip
        """`stopped`: whether an operator's stop has come since the batch was asked for
        (asked on the loop's thread, before each command)."""
        self.commands = tuple(commands)
        self._control = control
        self._stopped = stopped
        # Reads alone go one a job (the module's note); the answers so far.
        self._reads_only = all(command.kind == "get" for command in self.commands)
        self._answers: list[Answer] = []
        self._lock = threading.Lock()
        self._taken = False
        self._abandoned = False
        self._sent: Sent | None = None
        self._finished = threading.Event()

    def send(self) -> Sent:
        """Hand the batch to the loop and wait for what came of it (see the module's
        note for how long)."""
        self._control.submit(self._job, self._done)
        if self._finished.wait(TAKE_WAIT_S):
            return self._result()
        with self._lock:
            if not self._taken:
                self._abandoned = True
        if self._abandoned:
            return self._result(Sent(SendEnd.NO_LINK, why="not sent: the control loop did not "
                                     f"take the commands within {TAKE_WAIT_S:g} s"))  # fmt: skip
        if self._finished.wait(COMMAND_WAIT_S * len(self.commands)):
            return self._result()
        waited = TAKE_WAIT_S + COMMAND_WAIT_S * len(self.commands)
        return Sent(SendEnd.NO_LINK, why=f"the board did not answer within {waited:g} s: what "
                    "it took is not known")  # fmt: skip

    def _result(self, otherwise: Sent | None = None) -> Sent:
        # A job failed for want of a link (_fail_jobs) may have finished meanwhile.
        sent = self._sent if self._finished.is_set() else None
        result = sent or otherwise
        assert result is not None
        return result

    # -- on the loop's thread -------------------------------------------------------------

    def _job(self, link: BoardLink) -> Sent | None:
        with self._lock:
            if self._abandoned:
                return None  # its asker was told nothing was sent
            first, self._taken = not self._taken, True
        if first:
            refused = self._refusal()
            if refused is not None:
                return Sent(SendEnd.REFUSED, why=refused)
        left = self.commands[len(self._answers) :]
        if self._reads_only:
            left = left[:1]
        try:
            sent, lost = send_in_order(link, left, self._stopped, self._answers)
        except Exception:
            self._finish(Sent(SendEnd.FAILED, tuple(self._answers),
                              "the console failed sending them (logged)"))  # fmt: skip
            raise  # the loop's: it logs it and stops the robot
        if lost is not None:
            self._finish(sent)
            raise lost  # the loop's: it drops the link, or forgets the board's settings
        if sent.end is SendEnd.ANSWERED and len(self._answers) < len(self.commands):
            self._control.submit(self._job, self._done)  # the next read, after a tick
            return None
        return sent

    def _refusal(self) -> str | None:
        """Why the batch may not go now, or None: the guard, each command checked against
        the board's settings as those before it leave them; and nothing that can move the
        robot under a mission or the keys, which steer it themselves (a `get` may go)."""
        control = self._control
        moving = next((command for command in self.commands if command.kind != "get"), None)
        if moving is not None:
            mission = control.mission
            if mission is not None:
                return f"refused: {moving}: not while {mission.name} runs (a get may go)"
            if control.deadman.held() is not None or control.teleop.active:
                return f"refused: {moving}: not while the keys drive the robot (a get may go)"
        teleop = control.teleop
        board = teleop.board_settings
        for command in self.commands:
            try:
                check_command(command, teleop.limits, board)
            except CommandError as error:
                return f"refused: {command}: {error}"
            board.update(command.settings)
        return None

    def _done(self, outcome: object) -> None:
        """The job's result (None: more to come), or why the loop did not run it: no
        link (LinkError, from ControlLoop._fail_jobs), or a playback, during which only
        stops are sent."""
        if isinstance(outcome, Sent):
            self._finish(outcome)
        elif isinstance(outcome, LinkError):
            self._finish(Sent(SendEnd.NO_LINK, why=str(outcome)))
        elif isinstance(outcome, GiraffError):
            self._finish(Sent(SendEnd.REFUSED, why=str(outcome)))

    def _finish(self, sent: Sent) -> None:
        with self._lock:
            if self._sent is None:
                self._sent = sent
        self._finished.set()


def send_in_order(link: BoardLink, commands: Sequence[Command],
                  stopped: Callable[[], bool] = lambda: False,
                  answers: list[Answer] | None = None,
                  ) -> tuple[Sent, LinkError | BoardRebootedError | None]:  # fmt: skip
    """Send `commands` in order until the board refuses one, the link fails or `stopped`
    says a stop came; what came of them, with every answer so far (`answers`, added to),
    and the lost link or restarted board for the loop to act on."""
    answers = [] if answers is None else answers
    for command in commands:
        if stopped():
            return Sent(SendEnd.STOPPED, tuple(answers), f"stopped before {command}: "
                        "the operator's stop came first; it and those after it were not "
                        "sent"), None  # fmt: skip
        try:
            exchange = link.send(command)
        except LinkError as error:
            answers.append(Answer(command.text, error=error))
            return Sent(SendEnd.NO_LINK, tuple(answers), str(error)), error
        except BoardRebootedError as error:
            answers.append(Answer(command.text, error=error))
            return Sent(SendEnd.BOARD_RESTARTED, tuple(answers), str(error)), error
        except GiraffError as error:
            answers.append(Answer(command.text, error=error))
            return Sent(SendEnd.BOARD_REFUSED, tuple(answers), str(error)), None
        answers.append(Answer(command.text, exchange.value, exchange.lines))
    return Sent(SendEnd.ANSWERED, tuple(answers)), None
