"""`giraff-console send COMMAND...`: controller commands from the shell, within the limits.

Each COMMAND goes to the board and its decoded reply is printed. The commands pass the
same guard as the console's command line (robot/command_guard.py), with the console's
limits from the settings file: known names only (in any case; they go out in lower
case), bounded values, no `set p` that would let the robot run further than a dead
console may, no `set undock`, no line longer than the board's.

A `set p` is checked against the settings the board really holds: before anything is
sent, `send` reads r, v, a and vg from the board. The writable bits of `mode` cannot be
read back (A.4.8), so a move needs a `set mode 0` before it in the same call. Then every
command is checked, in order, against those settings as the commands before it leave
them: if one is refused, `send` says why and exits 1 without sending any of them. A
board error stops the rest too, since after it the board's settings are no longer known
for sure. Once `send` exits, the robot can run at most the console's runaway limit.

After connecting, `send` says on standard error which board answered: the probe's one
line (link/board_probe.py), the same as the console's status log. Standard output has
only the commands and their replies.

`--unsafe` lifts the checks, bar the line length, for bench work on a robot on blocks,
with a loud warning on standard error.

Exit codes: 0 all sent and answered, 1 a command refused (by the guard or the board),
2 a bad settings file, 3 a link that could not be used.
"""

from __future__ import annotations

import argparse
import struct
import sys
from collections.abc import Mapping, Sequence

from giraff_console.cli.simulator_options import add_firmware_option
from giraff_console.link import DEFAULT_TIMEOUT_S, BoardLink, LinkError, probe
from giraff_console.protocol import (
    BoardError,
    Command,
    CommandError,
    GiraffError,
    ModeBit,
    Number,
    ProtocolError,
    format_number,
    format_value,
    parse_command,
)
from giraff_console.robot.command_guard import check_command, check_line
from giraff_console.robot.teleop import DriveLimits
from giraff_console.robot.wheel_odometers import choose_reading
from giraff_console.runtime.simulator_url import IN_PROCESS_SIMULATOR, simulator_url

EXIT_SENT, EXIT_REFUSED, EXIT_USAGE, EXIT_LINK_ERROR = 0, 1, 2, 3
# What a move uses and the board can read back (A.4: every `set` has its `get`).
READ_FIRST = ("r", "v", "a", "vg")
UNSAFE_WARNING = (
    "giraff-console: WARNING: --unsafe: THE CONSOLE'S LIMITS ARE OFF. Commands go to the "
    "board unchecked, and a move carries on after send exits, as far as the board was "
    "told. Use it only with the robot on blocks."
)


class RefusedCommand(CommandError):
    """A command the guard refused, named in the message."""


def add_send_parser(commands: argparse._SubParsersAction) -> None:
    send = commands.add_parser(
        "send",
        help="send controller commands, within the console's limits, and print the replies",
        description="Send each COMMAND to the board and print its decoded reply. Without "
        "--port the built-in simulator answers. The commands are checked as the console's "
        "command line checks them, against the settings file's limits and the board's own "
        "settings (read first): a move needs r, mode 0, v, a and vg within the limits, and "
        "may not reach further than a dead console may let the robot run. If one command "
        "is refused, none is sent. Exits 0 when all were answered, 1 when one was refused "
        "(by the console or the board), 2 for a bad settings file, 3 when the port cannot "
        "be used.",
        epilog='example: giraff-console send "set v 0.3" "get v" "get bulk_data"',
    )
    send.add_argument(
        "--port",
        metavar="PORT|URL",
        help=f"serial device or pyserial URL (default: {IN_PROCESS_SIMULATOR}, the built-in "
        "simulator, with --firmware's board)",
    )
    add_firmware_option(send, after_command=True)
    send.add_argument(
        "--timeout",
        type=float,
        default=DEFAULT_TIMEOUT_S,
        metavar="S",
        help="seconds to wait for each reply (default: %(default)s)",
    )
    send.add_argument(
        "--power-line",
        choices=("dtr", "rts", "both", "none"),
        default="dtr",
        help="modem line that powers the board: dtr, or rts for FTDI cables",
    )
    send.add_argument(
        "--unsafe",
        action="store_true",
        help="DANGER: send without the console's limits, for bench work on a robot ON "
        "BLOCKS only; a move may carry on after send exits. Prints a warning.",
    )
    send.add_argument(
        "commands",
        nargs="+",
        metavar="COMMAND",
        help='a controller command, e.g. "get bulk_data" or "set v 0.3"',
    )


def run_send(args: argparse.Namespace) -> int:
    """Check and send `args.commands`; the exit code says how it went."""
    # Imported here, not with the parser: the settings' defaults load the robot's parts
    # (issue 26, item 6).
    from giraff_console.settings import SettingsError, load_settings

    try:
        commands = [parse_command(text) for text in args.commands]
        for command in commands:
            check_line(command)
        settings = load_settings(getattr(args, "config", None))
        limits = settings.teleop.limits()
    except SettingsError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    except CommandError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_REFUSED
    if args.unsafe:
        print(UNSAFE_WARNING, file=sys.stderr)
    try:
        link = BoardLink.open(
            args.port or simulator_url(getattr(args, "firmware", None)),
            timeout=args.timeout,
            power_line=args.power_line,
        )
    except LinkError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_LINK_ERROR
    except GiraffError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_REFUSED
    try:
        say_which_board(link, settings.board.odometers)
        return send_commands(link, commands, limits, unsafe=args.unsafe)
    except LinkError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_LINK_ERROR
    finally:
        link.close()


def say_which_board(link: BoardLink, odometers: str) -> None:
    """The probe's line on standard error, with the wheel reading the `[board]
    odometers` setting gives on this board. LinkError passes through."""
    try:
        features = probe(link)
    except LinkError:
        raise
    except GiraffError as error:
        print(f"giraff-console: could not tell which board this is: {error}", file=sys.stderr)
        return
    reading, _ = choose_reading(odometers, features)
    print(f"giraff-console: {features.describe(reading)}", file=sys.stderr)


def send_commands(link: BoardLink, commands: Sequence[Command], limits: DriveLimits, *,
                  unsafe: bool = False) -> int:  # fmt: skip
    """Check `commands` against the board's settings, then send them in order and print
    each reply; the exit code. Nothing is sent if one is refused, and nothing after a
    board error. LinkError if the link fails."""
    if not unsafe:
        try:
            check_all(commands, limits, read_settings(link))
        except RefusedCommand as refused:
            print(f"giraff-console: refused: {refused}; nothing was sent", file=sys.stderr)
            return EXIT_REFUSED
    for index, command in enumerate(commands):
        print(f"> {command}")
        try:
            exchange = link.send(command)
        except (BoardError, ProtocolError) as error:
            print(f"  {error}")
            if index + 1 < len(commands):
                print("giraff-console: nothing after it was sent", file=sys.stderr)
            return EXIT_REFUSED
        # A reply in an encoding of its own (the charger's) is shown as it came.
        raw = exchange.value is None and exchange.lines
        for line in exchange.lines if raw else describe(exchange.value):
            print(f"  {line}")
    return EXIT_SENT


def check_all(commands: Sequence[Command], limits: DriveLimits,
              board: Mapping[str, str]) -> None:  # fmt: skip
    """Raise RefusedCommand for the first command the guard refuses, each checked
    against `board` (the board's settings, as on the wire) as the ones before leave it."""
    board = dict(board)
    for command in commands:
        try:
            check_command(command, limits, board)
        except CommandError as error:
            raise RefusedCommand(f"{command}: {error}") from None
        board.update(command.settings)


def read_settings(link: BoardLink) -> dict[str, str]:
    """What the board holds for its next move (READ_FIRST), as it would go on the wire.

    A setting the board will not read back, or holds out of all reason, stays unknown,
    and a move that needs it is refused."""
    settings = {}
    for name in READ_FIRST:
        try:
            value = link.get(name)
        except (BoardError, ProtocolError):
            continue
        if value is None or isinstance(value, dict):
            continue
        try:
            settings[name] = _as_sent(value)
        except CommandError:
            continue
    return settings


def _as_sent(value: Number) -> str:
    """The text that was sent to leave `value` on the board. The board answers with a
    float32 (A.3), so `set v 0.4` reads back as 0.4000000059604645: the shortest decimal
    with the same float32 is what was sent, and what the limits are checked on."""
    text = format_number(value)  # CommandError for what no command could have sent
    if isinstance(value, float):
        single = struct.unpack("<f", struct.pack("<f", value))[0]
        for digits in range(1, 10):
            shortest = float(f"{value:.{digits}g}")
            if struct.unpack("<f", struct.pack("<f", shortest))[0] == single:
                return format_number(shortest)
    return text


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
