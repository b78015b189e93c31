"""`giraff-console stop`: the operator's stop from a shell, within 0.2 s of being typed
however busy the robot's PC (issue 30, item 3).

The program's entry point runs it before anything else of the package is loaded
(launch.py): besides the standard library it loads only the socket's transport and
wire format, where the socket lives, its own request (service/stop_request.py) and
the exit codes; not the other commands' parsers nor the robot. Typed as it is meant
to be (`stop`, `stop --daemon`) it does not build its parser either: argparse and
what its help formatter loads (gettext, shutil) were a third of its start-up's
imports, and a Python program starting beside two busy processes is most of the
stop's 0.2 s. Anything else (`--help`, a mistake) goes to the parser as before.
It starts no thread and moves nothing itself, so it takes its signals as any program
does, whatever mask it was started with. The same parser is one of the full command
line's (main.py), so `giraff-console --help` lists it and `giraff-console --config
FILE stop` stops as well.
"""

from __future__ import annotations

import signal
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING

from giraff_console.cli.exit_codes import EXIT_DONE, EXIT_FAILED, EXIT_NO_DAEMON
from giraff_console.service.runtime_folder import socket_path
from giraff_console.service.stop_request import ask_stop
from giraff_console.service.transport import NoDaemon, TransportError

if TYPE_CHECKING:
    import argparse

HELP = "stop the robot now (and, with --daemon, the daemon)"
DESCRIPTION = (
    "Stop the robot the daemon runs: let go of the keys, end the mission, stop the "
    "wheels. Anyone may, whoever holds the controls. Exits 3 when no daemon runs."
)
# Ended by Ctrl-C, as shells report it (128 + SIGINT).
EXIT_INTERRUPTED = 128 + signal.SIGINT


def add_stop_parser(commands: argparse._SubParsersAction) -> None:
    """`stop` among the full command line's commands."""
    parser = commands.add_parser("stop", help=HELP, description=DESCRIPTION, allow_abbrev=False)
    _add_arguments(parser)


def main(argv: Sequence[str]) -> int:
    """`giraff-console stop ARGS`, on its own: its parser alone."""
    # A parent that blocks them for its own watcher (the console) would otherwise leave
    # this stop deaf to Ctrl-C and SIGTERM until its timeout.
    signal.pthread_sigmask(signal.SIG_SETMASK, set())
    if list(argv) in ([], ["--daemon"]):
        return run_stop(shutdown=bool(argv))
    import argparse  # only for help and mistakes (see the module's note)

    parser = argparse.ArgumentParser(prog="giraff-console stop", description=DESCRIPTION,
                                     allow_abbrev=False)  # fmt: skip
    _add_arguments(parser)
    return run_stop(shutdown=parser.parse_args(argv).daemon)


def _add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--daemon", action="store_true",
        help="then end the daemon too (as systemctl --user stop does)",
    )  # fmt: skip


def run_stop(shutdown: bool) -> int:
    """Ask the daemon to stop the robot (and with `shutdown`, itself); the exit code."""
    try:
        answer = ask_stop(socket_path(), shutdown=shutdown)
    except NoDaemon as error:
        print(f"giraff-console: {error}; `giraff-console serve` starts one", file=sys.stderr)
        return EXIT_NO_DAEMON
    except TransportError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_FAILED
    except KeyboardInterrupt:
        print("giraff-console: interrupted before the daemon answered; whether the robot "
              "stopped, `giraff-console status` tells", file=sys.stderr)  # fmt: skip
        return EXIT_INTERRUPTED
    print(f"giraff-console: {answer.text or 'stopped'}", file=sys.stderr)
    return EXIT_DONE if answer.ok else EXIT_FAILED
