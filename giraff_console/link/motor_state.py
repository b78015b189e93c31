"""The board's motor state from one `get bulk_data` (A.4.21), with its quirks undone."""

from __future__ import annotations

import math
from dataclasses import dataclass

from giraff_console.protocol.codec import Number
from giraff_console.protocol.errors import ProtocolError
from giraff_console.protocol.kinematics import speed_from_gvr
from giraff_console.protocol.mode import ModeBit

_REQUIRED = ("cang", "cdis", "gvr", "cvg", "mode")


@dataclass(frozen=True)
class MotorState:
    """One odometry sample.

    - `cang`: degrees rotated in place, positive in the sense of a positive `set p`
      (clockwise). The board reports it with the opposite sign (A.2.2).
    - `cdis`: metres travelled in straight or curved motion.
    - `gvr`: the raw reading: m/s in straight motion, the left wheel's speed by the
      manufacturer's formula in curved motion (§3.2.1.4), minus degrees/s in rotation.
    - `speed`: the overall speed in straight or curved motion, gvr * (1 - cvg); None
      when that cannot be known: at vg = 1 the board reports an infinite gvr (§3.2.1.4).
    - `imdl`, `imdr`: metres turned by the left and right wheels: since power-up on the
      thesis's board, since the previous read on later ones (robot/wheel_odometers.py).
      The control loop hands teleop and the missions totals whatever the board, the
      odometry's sums where the board's are not (robot/odometry_feed.py). Boards and
      logs without them give None, as does the tilt.
    - `enc0`, `enc1`: the left and right wheel encoders' 16-bit counts, which are not
      in bulk_data: the control loop reads them after the poll when it needs them
      (later boards only); None otherwise.
    """

    cang: float
    cdis: float
    gvr: float
    speed: float | None
    cvg: float
    tilt: float | None
    imdl: float | None
    imdr: float | None
    mode: int
    received_at: float
    enc0: int | None = None
    enc1: int | None = None

    @property
    def estop(self) -> bool:
        return bool(self.mode & ModeBit.ESTOP)

    @property
    def moving(self) -> bool:
        return bool(self.mode & ModeBit.MOVING)

    @property
    def absolute(self) -> bool:
        return bool(self.mode & ModeBit.ABSOLUTE)

    @classmethod
    def from_bulk(cls, values: dict[str, Number], received_at: float) -> MotorState:
        """Build from a decoded bulk_data list; ProtocolError if a needed field is missing."""
        missing = [name for name in _REQUIRED if name not in values]
        if missing:
            raise ProtocolError(f"bulk_data without {', '.join(missing)}")

        def optional(name: str) -> float | None:
            return float(values[name]) if name in values else None

        gvr, cvg = float(values["gvr"]), float(values["cvg"])
        speed = speed_from_gvr(gvr, cvg)
        return cls(
            cang=-float(values["cang"]),
            cdis=float(values["cdis"]),
            gvr=gvr,
            speed=speed if math.isfinite(speed) else None,
            cvg=cvg,
            tilt=optional("tilt_angle_from_home"),
            imdl=optional("imdl"),
            imdr=optional("imdr"),
            mode=_mode_bits(values["mode"]),
            received_at=received_at,
        )


def _mode_bits(value: Number) -> int:
    """The mode bitmask; a board or a recording may garble it into inf or NaN (A.4.8)."""
    if not math.isfinite(value) or value != int(value):
        raise ProtocolError(f"bulk_data with a mode that is not a bitmask: {value!r}")
    return int(value)
