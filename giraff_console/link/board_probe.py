"""Which board the console talks to: what a later firmware adds, probed once after connecting.

Deployed Giraffs run firmware newer than the thesis's (wire-facts, "Later firmware, as
real drivers use it"): wheel encoders `enc0`/`enc1`, a battery charger `charger_data`
and, on Giraff-X, the one-command curve `twm`; some units of any firmware also have a
height stalk `h`. A board without one of them answers `Unknown name`, so a `get` of each
tells them apart without moving anything. The banner's version says which firmware it
is, but real later boards' version strings are not known, so the answers decide, not
the version.

`get twm` is an assumption: wire-facts documents only `set twm`, and only our simulator
is known to answer the `get`. A real Giraff-X that answers `Unknown name` to it is
taken as without twm unless the settings say otherwise (`[board] twm`).

The probe never reads `bulk_data`: on a later board that read resets `imdl`/`imdr`, and
the odometry would lose what the wheels did before it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

from giraff_console.link.board_link import BoardLink
from giraff_console.protocol.codec import Command
from giraff_console.protocol.errors import (
    BoardError,
    BoardRebootedError,
    ProtocolError,
    UnknownNameError,
)

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BoardFeatures:
    """What a board answered to the probe."""

    version: str | None
    encoders: bool
    stalk: bool
    charger: bool
    twm: bool

    @property
    def later_firmware(self) -> bool:
        """Encoders, a charger or twm mark a later firmware (wire-facts lists them among
        what real drivers use on later boards). A height stalk alone does not: wire-facts
        has it among the general quirks ("Some units also have a height stalk"), so a
        board of the thesis's firmware may have one, and taking it for a later board
        would read its imdl/imdr totals as increments."""
        return self.encoders or self.charger or self.twm

    def describe(self, odometers: str | None = None, twm: bool | None = None) -> str:
        """One line for the status log. `odometers` is how imdl/imdr (or the encoders)
        are read; without it, as the firmware suggests. `twm`: whether curves go out as
        one twm, when the settings chose otherwise than the probe found."""
        board = f"board {self.version}" if self.version else "board version unknown"
        names = [
            name
            for name, present in (
                ("encoders", self.encoders),
                ("height stalk", self.stalk),
                ("charger", self.charger),
                ("twm", self.twm),
            )
            if present
        ]
        if self.later_firmware:
            kind = f"later firmware ({', '.join(names)})"
        elif names:
            kind = f"the thesis's firmware, with a {', '.join(names)}"
        else:
            kind = "the thesis's firmware"
        if odometers is None:
            odometers = "increments" if self.later_firmware else "totals"
        if odometers == "encoders":
            reading = "odometry from the wheel encoders"
        else:
            reading = f"imdl/imdr read as {odometers}"
        line = f"{board}: {kind}; {reading}"
        if twm is not None and twm != self.twm:
            line += "; curves as one twm, as the settings say" if twm else (
                "; twm not used, as the settings say")  # fmt: skip
        return line


# What each feature answers to; `get` of each is harmless on every board.
PROBES = {"encoders": "enc0", "stalk": "h", "charger": "charger_data", "twm": "twm"}


def probe(link: BoardLink) -> BoardFeatures:
    """Ask the board for each later firmware's parameter; `Unknown name` means absent.

    LinkError (and BoardRebootedError) pass through: the caller's reconnect handles them.
    """
    found = {feature: _answers(link, name) for feature, name in PROBES.items()}
    return BoardFeatures(version=link.version, **found)


def _answers(link: BoardLink, name: str) -> bool:
    try:
        # The console's own traffic, like its polls: kept out of the transcript, where a
        # thesis board's `Unknown name` answers would only alarm the operator.
        link.send(Command("get", name), automatic=True)
    except UnknownNameError:
        return False
    except BoardRebootedError:
        raise
    except ProtocolError as error:
        # An answer that cannot be read: the console relies on nothing it could not read.
        log.warning("probe: get %s answered unreadably (%s); taken as absent", name, error)
        return False
    except BoardError:
        # An error line other than `Unknown name`: the board knows the name.
        return True
    return True
