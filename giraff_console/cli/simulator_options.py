"""The option that chooses the built-in simulator's firmware, for the console, `go`,
`send` and `sim` alike.

It sits above the simulator, as the command line does: the simulator knows nothing of
the console.
"""

from __future__ import annotations

import argparse

from giraff_console.sim.firmware import DEFAULT_FIRMWARE, FIRMWARES

FIRMWARE_HELP = (
    "the simulator's firmware: thesis (the thesis's 2013 board), later (incremental "
    "imdl/imdr, enc0/enc1, the h stalk, charger_data, mode 2) or giraff-x (later plus set "
    f"twm); docs/simulator.md lists the differences (default: {DEFAULT_FIRMWARE})"
)


def add_firmware_option(parser: argparse.ArgumentParser, *, after_command: bool = False) -> None:
    """`--firmware NAME`. `after_command`: the copy a command takes after its name
    (`go ROOM --firmware later`), which leaves the one given before it alone when not
    given itself (`giraff-console --firmware later go ROOM`)."""
    default = argparse.SUPPRESS if after_command else None
    parser.add_argument("--firmware", choices=tuple(FIRMWARES), default=default,
                        metavar="NAME", help=FIRMWARE_HELP)  # fmt: skip
