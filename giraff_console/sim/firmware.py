"""The firmware a simulated board runs: the thesis's, or a later one that deployed robots run.

The thesis documents one board (Appendix A, 2013). Two independent open-source drivers
used on deployed Giraffs talk to newer boards (wire-facts, "Later firmware, as real
drivers use it"): `imdl`/`imdr` read as increments, wheel encoders, a height stalk, a
battery charger, `mode 2`, and on Giraff-X the one-command curved move `twm`. A profile
says which of these a simulated board has. docs/simulator.md lists every difference and
its source.

Real boards' version strings for the later firmware are not known: the ones here are
made up, and only have to tell the profiles apart as a real banner would.
"""

from __future__ import annotations

from dataclasses import dataclass

# The undocumented `mode 2` of later boards: `vg` is an angular velocity in degrees per
# second (wire-facts "Quirks"). Not a ModeBit: the thesis's board ignores it.
ANGULAR_MODE_BIT = 2


@dataclass(frozen=True)
class Firmware:
    """A board's firmware: its banner and what it can do beyond the thesis's board."""

    name: str
    version: str
    date: str
    # `imdl`/`imdr` are the wheels' travel since the previous `get bulk_data` (a read
    # resets them), not since power-up (wire-facts: the ROS 2 driver adds them up).
    incremental_odometers: bool = False
    # `enc0`/`enc1`: 16-bit wheel encoder counters, get and set.
    encoders: bool = False
    # `h`: the height stalk, 0..1000.
    stalk: bool = False
    # `get charger_data` and a battery that drains and charges on the dock.
    charger: bool = False
    # Mode bit 2: `vg` is an angular velocity in degrees per second.
    angular_mode: bool = False
    # `set twm vg cdp vgr v p 0` and `get twm` (Giraff-X).
    twm: bool = False
    # `set p` with v = 0 or a = 0 brakes the robot to a stop instead of being refused:
    # both real drivers stop a robot that way (wire-facts "Stopping").
    zero_speed_brakes: bool = False
    # The head homes by itself at power-up (A.4.10): neither deployed driver sends `home`,
    # and one waits for `tilt_homing_state` to read 3 before it starts (wire-facts "Tilt
    # before homing"). The thesis's simulator homes only when told (or with auto_home).
    homes_at_power_up: bool = False


_LATER = {
    "incremental_odometers": True,
    "encoders": True,
    "stalk": True,
    "charger": True,
    "angular_mode": True,
    "zero_speed_brakes": True,
    "homes_at_power_up": True,
}

FIRMWARES: dict[str, Firmware] = {
    firmware.name: firmware
    for firmware in (
        # The thesis's board and simulator (Appendix A, B.2): today's behaviour exactly.
        Firmware("thesis", "1.1.112p-sim", "2013-06-01"),
        Firmware("later", "1.4.226-sim", "2015-09-14", **_LATER),
        Firmware("giraff-x", "X2.0.9-sim", "2017-03-02", **_LATER, twm=True),
    )
}
DEFAULT_FIRMWARE = "thesis"


def firmware_named(name: str) -> Firmware:
    """The profile called `name`; ValueError naming the choices for any other."""
    try:
        return FIRMWARES[name]
    except KeyError:
        raise ValueError(f"firmware must be one of {', '.join(FIRMWARES)}") from None
