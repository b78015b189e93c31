"""`giraff-console send COMMAND...`: controller commands from the shell, within the limits.

Each COMMAND goes to the board and its decoded reply is printed. `send` is a client of
the robot service, like every front end (design.md): when a daemon runs (`giraff-console
serve`), it asks the daemon, which has the board; else it builds the robot in its own
process (runtime/robot.py) on `--port`, or on the built-in simulator, and asks that
robot's service. Either way the request is the same (c.SendCommands), and so is the
guard: the console's command line's (robot/command_guard.py), with the limits of the
settings file the robot was started with: known names only (in any case; they go out in
lower case), bounded values, no `set p` that would let the robot run further than a dead
console may, no `set undock`, no line longer than the board's.

The commands are checked on the control loop's thread, against the board's settings as
the loop knows them (it sets them within the limits as it connects, and sees every
command that reaches the board), each as the commands before it leave them: if one is
refused, `send` says why and exits 1 without sending any of them. A board error stops
the rest too, since after it the board's settings are no longer known for sure. Who
may send is the service's to say: anyone may read (`get`), but a `set` or a bare command
needs the controls, as a key does, and is refused while a mission or the keys drive.

In its own process `send` waits, after a move, until the wheels are still (at most
MOVE_WAIT_S), since the robot is stopped when the process ends; beside the daemon it
exits at once and the daemon's loop looks after the move. Either way, once `send` exits
the robot can run at most the console's runaway limit.

After connecting, `send` says on standard error which board answered: the probe's one
line (link/board_probe.py), the same as the console's status log. Standard output has
only the commands and their replies.

`--unsafe` lifts the checks, bar the line length, for bench work on a robot on blocks,
with a loud warning on standard error. It cannot go through the service: the service
has one guard and no way round it, or any console attached to the daemon could ask for
the same. So `--unsafe` opens the port itself, as a bench tool, and is refused while a
daemon runs (the daemon holds the board; stop it first).

Exit codes: 0 all sent and answered, 1 a command refused (by the guard, the service or
the board) or an operator's stop that came first, 2 a bad settings file or a mistake in
the options, 3 a link (or a daemon) that could not be used, or a board that restarted.
"""

from __future__ import annotations

import argparse
import queue
import sys
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING

# Light modules only: the parser is built with every command's (cli/main.py). What
# `send` talks to is imported when it runs (issue 26, item 6).
from giraff_console.cli.simulator_options import add_firmware_option
from giraff_console.protocol import (
    Command,
    CommandError,
    GiraffError,
    ModeBit,
    Number,
    format_value,
    parse_command,
)
from giraff_console.robot.command_guard import check_line
from giraff_console.runtime.simulator_url import IN_PROCESS_SIMULATOR

if TYPE_CHECKING:
    from giraff_console.link import BoardLink
    from giraff_console.link.board_probe import BoardFeatures
    from giraff_console.robot.telemetry import Telemetry
    from giraff_console.service.events import Reply, Sent, ServiceEvent
    from giraff_console.service.remote import RemoteRobot
    from giraff_console.settings import Settings

EXIT_SENT, EXIT_REFUSED, EXIT_USAGE, EXIT_LINK_ERROR = 0, 1, 2, 3
UNSAFE_WARNING = (
    "giraff-console: WARNING: --unsafe: THE CONSOLE'S LIMITS ARE OFF. Commands go to the "
    "board unchecked, and a move carries on after send exits, as far as the board was "
    "told. Use it only with the robot on blocks."
)
# Seconds of real time for the board's first answer in this process (a real board's
# power-up greeting included), and for a move sent to end before the robot is stopped
# as `send` ends (a move within the reach takes a second or two at teleop's speeds).
CONNECT_TIMEOUT_S = 10.0
MOVE_WAIT_S = 30.0
# Seconds beyond the service's own bound (command_batch.py) that the daemon's answer
# may take to cross the socket.
ANSWER_MARGIN_S = 5.0


def add_send_parser(commands: argparse._SubParsersAction) -> None:
    send = commands.add_parser(
        "send",
        help="send controller commands, within the console's limits, and print the replies",
        description="Send each COMMAND to the board and print its decoded reply. When a "
        "daemon runs (giraff-console serve), it is asked, and sends them to its board; "
        "else the robot is started in this process, on --port or the built-in simulator, "
        "and stopped as send ends (after a move, once the wheels are still). The commands "
        "are checked as the console's command line checks them, against the settings "
        "file's limits and the board's settings as the console set them: a move needs r, "
        "mode 0, v, a and vg within the limits, and may not reach further than a dead "
        "console may let the robot run. If one command is refused, none is sent. A get "
        "may be sent by anyone; a set needs the controls (nobody else holding them) and no "
        f"mission running. At most {_max_commands()} commands at once. Exits 0 when all "
        "were answered, 1 when one was refused (by the console or the board) or an "
        "operator's stop came first, 2 for a bad settings file or options, 3 when the port "
        "(or the daemon) cannot be used or the board restarted.",
        epilog='example: giraff-console send "set v 0.3" "get v" "get bulk_data"',
    )
    send.add_argument(
        "--port",
        metavar="PORT|URL",
        help=f"serial device or pyserial URL (default: {IN_PROCESS_SIMULATOR}, the built-in "
        "simulator, with --firmware's board); not while a daemon runs: it has the board",
    )
    add_firmware_option(send, after_command=True)
    send.add_argument(
        "--timeout",
        type=float,
        metavar="S",
        help="seconds to wait for each reply (default: the settings file's timeout, 1 s); "
        "a daemon uses its own",
    )
    send.add_argument(
        "--power-line",
        choices=("dtr", "rts", "both", "none"),
        help="modem line that powers the board: dtr, or rts for FTDI cables (default: the "
        "settings file's, dtr); a daemon uses its own",
    )
    send.add_argument(
        "--unsafe",
        action="store_true",
        help="DANGER: send without the console's limits, for bench work on a robot ON "
        "BLOCKS only; a move may carry on after send exits. Prints a warning. Opens the "
        "port itself, so not while a daemon runs.",
    )
    send.add_argument(
        "commands",
        nargs="+",
        metavar="COMMAND",
        help='a controller command, e.g. "get bulk_data" or "set v 0.3"',
    )


def _max_commands() -> int:
    from giraff_console.service.commands import MAX_COMMANDS

    return MAX_COMMANDS


def run_send(args: argparse.Namespace) -> int:
    """Check and send `args.commands`; the exit code says how it went."""
    # Imported here, not with the parser: the settings' defaults load the robot's parts
    # (issue 26, item 6).
    from dataclasses import replace

    from giraff_console.settings import SettingsError, load_settings

    try:
        commands = [parse_command(text) for text in args.commands]
        for command in commands:
            check_line(command)
        if not args.unsafe and len(commands) > _max_commands():
            raise CommandError(f"at most {_max_commands()} commands at once, not "
                               f"{len(commands)}: send them in more than one call")  # fmt: skip
        settings = load_settings(getattr(args, "config", None))
    except SettingsError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    except CommandError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_REFUSED
    if args.timeout is not None:
        if not args.timeout > 0:
            print("giraff-console: --timeout must be positive", file=sys.stderr)
            return EXIT_USAGE
        settings = replace(settings, timeout=args.timeout)
    if args.power_line is not None:
        settings = replace(settings, power_line=args.power_line)
    if args.port is not None and args.firmware is not None:
        print("giraff-console: --firmware: only for the built-in simulator (without --port)",
              file=sys.stderr)  # fmt: skip
        return EXIT_USAGE
    if args.unsafe:
        return send_unsafe(args, commands, settings)
    attached = attach_if_running(args)
    if isinstance(attached, int):
        return attached
    if attached is not None:
        return send_there(attached, commands, settings)
    return send_here(args, commands, settings)


# -- through the service --------------------------------------------------------------


def attach_if_running(args: argparse.Namespace) -> RemoteRobot | int | None:
    """The running daemon's robot, attached as a console that does not ask for the
    controls (a set takes them only if nobody holds them); None when no daemon runs; an
    exit code when one runs but cannot be used, or the command names a port of its own."""
    from giraff_console.cli.daemon import daemon_robot
    from giraff_console.service.runtime_folder import socket_path
    from giraff_console.service.transport import NoDaemon, TransportError

    try:
        robot = daemon_robot("send")
    except NoDaemon:
        return None
    except TransportError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_LINK_ERROR
    if args.port is not None:
        robot.close()
        print(f"giraff-console: the daemon at {socket_path()} has the robot; leave out "
              "--port to ask it, or stop it (giraff-console stop --daemon)",
              file=sys.stderr)  # fmt: skip
        return EXIT_USAGE
    print(f"giraff-console: asking the daemon at {socket_path()}", file=sys.stderr)
    ignored = [option for option, name in (("--firmware", "firmware"), ("--timeout", "timeout"),
                                           ("--power-line", "power_line"))
               if getattr(args, name, None) is not None]  # fmt: skip
    if ignored:
        print(f"giraff-console: {', '.join(ignored)} ignored: the daemon's are used",
              file=sys.stderr)  # fmt: skip
    return robot


def send_there(remote: RemoteRobot, commands: Sequence[Command], settings: Settings) -> int:
    """Ask the daemon to send `commands` and print what came of them."""
    import threading

    from giraff_console.service import commands as c
    from giraff_console.service.command_batch import COMMAND_WAIT_S, TAKE_WAIT_S

    timeout = TAKE_WAIT_S + COMMAND_WAIT_S * len(commands) + ANSWER_MARGIN_S
    replies: list[Reply] = []
    answered = threading.Event()

    def heard(reply: Reply) -> None:
        replies.append(reply)
        answered.set()

    try:
        telemetry = remote.welcome.situation.telemetry
        if telemetry is not None and telemetry.board is not None:
            say_which_board(telemetry.board, settings.board.odometers)
        remote.post(c.SendCommands(tuple(command.text for command in commands)), heard)
        if not answered.wait(timeout):
            print(f"giraff-console: no answer from the daemon in {timeout:g} s; what it "
                  "sent is not known", file=sys.stderr)  # fmt: skip
            return EXIT_LINK_ERROR
    except KeyboardInterrupt:
        print("giraff-console: interrupted; what the daemon sent is not known", file=sys.stderr)
        return 130
    finally:
        remote.close()
    reply = replies[0]
    if reply.sent is None and remote.gone is not None:
        print(f"giraff-console: {reply.text}", file=sys.stderr)
        return EXIT_LINK_ERROR
    return said(reply, len(commands))


def send_here(args: argparse.Namespace, commands: Sequence[Command], settings: Settings) -> int:
    """Start the robot in this process, ask its service to send `commands`, print what
    came of them, wait for a move to end, and stop the robot."""
    from giraff_console.data_folders import example_floorplan
    from giraff_console.robot.telemetry import LinkState
    from giraff_console.runtime.options import RobotOptions, UsageError
    from giraff_console.runtime.robot import Robot
    from giraff_console.service import commands as c

    # No markers: `send` drives nowhere by the pose, and a real robot's camera is not
    # opened for them.
    options = RobotOptions(port=args.port, firmware=args.firmware, landmarks=False)
    try:
        robot = Robot(options, settings, example_floorplan())
    except UsageError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    events: queue.Queue[ServiceEvent] = queue.Queue()
    with robot:
        robot.service.subscribe(events.put)
        robot.guard()
        robot.start()
        # The loop's first snapshot follows its first try at the board: one try, as a
        # command from the shell makes, not the console's retries.
        first, notes = _first_snapshot(events)
        if first is None or first.link is not LinkState.CONNECTED:
            for text in notes:
                # One try: the loop's promise to retry is not send's.
                print(f"giraff-console: {text.partition('; retrying')[0]}", file=sys.stderr)
            print("giraff-console: no link to the board; nothing was sent", file=sys.stderr)
            return EXIT_LINK_ERROR
        if first.board is not None:
            say_which_board(first.board, settings.board.odometers)
        reply = robot.service.execute(c.SendCommands(tuple(cmd.text for cmd in commands)))
        code = said(reply, len(commands))
        if reply.sent is not None and _moved(reply.sent):
            _wait_until_still(events)
        return code


def _moved(sent: Sent) -> bool:
    """Whether a command that may move the robot (a set, home) reached the board."""
    from giraff_console.protocol import parse_command

    return any(answer.error is None and parse_command(answer.command).kind != "get"
               for answer in sent.answers)  # fmt: skip


def _first_snapshot(events: queue.Queue[ServiceEvent]) -> tuple[Telemetry | None, list[str]]:
    """The loop's first snapshot, within CONNECT_TIMEOUT_S, and the notes before it."""
    from giraff_console.robot.loop_events import Note
    from giraff_console.robot.telemetry import Telemetry

    notes: list[str] = []
    deadline = time.monotonic() + CONNECT_TIMEOUT_S
    while (remaining := deadline - time.monotonic()) > 0:
        try:
            event = events.get(timeout=remaining)
        except queue.Empty:
            break
        if isinstance(event, Telemetry):
            return event, notes
        if isinstance(event, Note):
            notes.append(event.text)
    return None, notes


def _wait_until_still(events: queue.Queue[ServiceEvent]) -> None:
    """Wait, at most MOVE_WAIT_S, until a snapshot polled after the commands shows the
    wheels still (the robot is stopped as this process ends), or the link gone."""
    from giraff_console.robot.telemetry import LinkState, Telemetry

    # The commands' job ran, and was answered, before the poll of its tick: what is
    # queued by now may be older, and a snapshot from after it comes again next tick.
    while not events.empty():
        events.get_nowait()
    told = False
    deadline = time.monotonic() + MOVE_WAIT_S
    while (remaining := deadline - time.monotonic()) > 0:
        try:
            event = events.get(timeout=remaining)
        except queue.Empty:
            break
        if not isinstance(event, Telemetry):
            continue
        if event.link is not LinkState.CONNECTED:
            return
        if event.state is not None and not event.state.moving:
            return
        if not told:
            print("giraff-console: the robot moves; send ends once it stops (Ctrl-C stops it "
                  "now)", file=sys.stderr)  # fmt: skip
            told = True
    print(f"giraff-console: the robot still moves after {MOVE_WAIT_S:g} s; it is stopped as "
          "send ends", file=sys.stderr)  # fmt: skip


# -- what came of them ----------------------------------------------------------------


def said(reply: Reply, count: int) -> int:
    """Print what came of `count` commands asked for; the exit code."""
    if reply.sent is None:
        # Refused before the commands were looked at: who may send (the controls).
        print(f"giraff-console: {reply.text}; nothing was sent", file=sys.stderr)
        return EXIT_REFUSED
    return print_sent(reply.sent, count)


def print_sent(sent: Sent, count: int) -> int:
    """Each command sent and its decoded answer on standard output, why the rest were not
    on standard error; the exit code."""
    from giraff_console.service.events import SendEnd

    if sent.end is SendEnd.REFUSED:
        print(f"giraff-console: {sent.why}; nothing was sent", file=sys.stderr)
        return EXIT_REFUSED
    for answer in sent.answers:
        print(f"> {answer.command}")
        if answer.error is None:
            # A reply in an encoding of its own (the charger's) is shown as it came.
            raw = answer.value is None and answer.lines
            for line in answer.lines if raw else describe(answer.value):
                print(f"  {line}")
        elif sent.end is SendEnd.BOARD_REFUSED:
            print(f"  {answer.error}")
    if sent.end is SendEnd.ANSWERED:
        return EXIT_SENT
    if sent.end is SendEnd.BOARD_REFUSED:
        if len(sent.answers) < count:
            print("giraff-console: nothing after it was sent", file=sys.stderr)
        return EXIT_REFUSED
    print(f"giraff-console: {sent.why}", file=sys.stderr)
    return EXIT_REFUSED if sent.end is SendEnd.STOPPED else EXIT_LINK_ERROR


def say_which_board(features: BoardFeatures, odometers: str) -> None:
    """The probe's line on standard error, with the wheel reading the `[board]
    odometers` setting gives on this board."""
    from giraff_console.robot.wheel_odometers import choose_reading

    reading, _ = choose_reading(odometers, features)
    print(f"giraff-console: {features.describe(reading)}", file=sys.stderr)


def describe(value: object) -> list[str]:
    """Lines that show a decoded reply: one per field for lists."""
    if value is None:
        return ["OK"]
    if isinstance(value, dict):
        width = max(len(name) for name in value)
        return [f"{name:<{width}}  {describe_field(name, field)}" for name, field in value.items()]
    assert isinstance(value, int | float)
    return [format_value(value)]


def describe_field(name: str, value: Number) -> str:
    """A field's value; the mode bitmask also gets the names of its bits."""
    text = format_value(value)
    if name == "mode" and isinstance(value, int) and value:
        bits = [bit.name for bit in ModeBit if value & bit]
        text += f" ({', '.join(str(b) for b in bits)})"
    return text


# -- --unsafe: the bench's own link ---------------------------------------------------


def send_unsafe(args: argparse.Namespace, commands: Sequence[Command], settings: Settings) -> int:
    """Send `commands` unchecked over a link of this command's own (see the module's
    note for why not through the service), unless a daemon has the board."""
    from giraff_console.link import BoardLink, LinkError, probe
    from giraff_console.runtime.simulator_url import simulator_url
    from giraff_console.service.daemon import daemon_alive
    from giraff_console.service.runtime_folder import socket_path
    from giraff_console.service.transport import TransportError

    try:
        path = socket_path()
    except TransportError:
        path = None  # no runtime folder: no daemon either
    if path is not None and daemon_alive(path):
        print(f"giraff-console: --unsafe opens the port itself, and the daemon at {path} has "
              "the board: stop the daemon first (giraff-console stop --daemon), or leave "
              "out --unsafe to ask it within the limits", file=sys.stderr)  # fmt: skip
        return EXIT_USAGE
    print(UNSAFE_WARNING, file=sys.stderr)
    try:
        link = BoardLink.open(args.port or simulator_url(args.firmware),
                              timeout=settings.timeout, power_line=settings.power_line)  # fmt: skip
    except LinkError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_LINK_ERROR
    except GiraffError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_REFUSED
    try:
        try:
            say_which_board(probe(link), settings.board.odometers)
        except LinkError:
            raise
        except GiraffError as error:
            print(f"giraff-console: could not tell which board this is: {error}",
                  file=sys.stderr)  # fmt: skip
        return print_sent(send_unchecked(link, commands), len(commands))
    except LinkError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_LINK_ERROR
    finally:
        link.close()


def send_unchecked(link: BoardLink, commands: Sequence[Command]) -> Sent:
    """Send `commands` in order, unchecked, until the board refuses one or the link
    fails: what came of them, as the service says it (Sent)."""
    from giraff_console.service.command_batch import send_in_order

    sent, _ = send_in_order(link, commands)
    return sent
