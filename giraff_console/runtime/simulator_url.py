"""The in-process simulator's URL, apart from the board it reaches: `send --help` shows
it, which must not pay for loading the robot (issue 26, item 6). board.py builds the
simulator with it.
"""

from __future__ import annotations

IN_PROCESS_SIMULATOR = "giraff-sim://"


def simulator_url(firmware: str | None, *, virtual_clock: bool = False,
                  imperfect_seed: int | None = None) -> str:  # fmt: skip
    """The in-process simulator's URL: with the firmware asked for (if any), on a
    virtual clock, with the imperfection model seeded."""
    options = ["clock=virtual"] if virtual_clock else []
    if imperfect_seed is not None:
        options += ["imperfect=1", f"seed={imperfect_seed}"]
    if firmware is not None:
        options.append(f"firmware={firmware}")
    return IN_PROCESS_SIMULATOR + ("?" + "&".join(options) if options else "")
