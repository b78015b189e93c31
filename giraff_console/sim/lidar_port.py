"""The simulated RPLIDAR as a pyserial port: `serial.serial_for_url("giraff-lidar://...")`.

Options go in the query string, for example `giraff-lidar://?rate=10&samples=400`:

| option          | values                 | meaning                                           |
|-----------------|------------------------|---------------------------------------------------|
| rate            | 1 to 20                | revolutions a second (default 5.5, an A1's)        |
| samples         | 16 to 4000             | samples a revolution (default 360)                 |
| imperfect, seed | 0/1, integer           | the datasheet's range noise, seeded                |
| health          | good, warning, error   | what GET_HEALTH says (error: it will not scan)     |

What it sees is set on the port before it is opened: `port.world` (a `LidarWorld`), and
`port.clock` (the simulated board's, when that runs on a virtual clock: samples then
come at the board's time). Without a world it sees nothing. Reads wait in real time for
at most the port's timeout, whatever the clock, so that a reader never hangs.
"""

from __future__ import annotations

import time
import urllib.parse
from collections.abc import Callable

from serial import PortNotOpenError, SerialBase, SerialException

from giraff_console.protocol.rplidar import Health
from giraff_console.sim.lidar import A1_RATE_HZ, A1_SAMPLES, LidarConfig, LidarWorld, SimLidar

SCHEME = "giraff-lidar"
# The longest a read sleeps before looking again: a few samples' time at 2000 a second.
POLL_S = 0.002
HEALTH = {"good": Health.GOOD, "warning": Health.WARNING, "error": Health.ERROR}


class Serial(SerialBase):
    """A pyserial port with a simulated RPLIDAR on the other end."""

    is_open: bool

    def __init__(self, *args, **kwargs) -> None:
        self.world: LidarWorld | None = None
        self.clock: Callable[[], float] = time.monotonic
        self.lidar: SimLidar | None = None
        self._in = bytearray()
        super().__init__(*args, **kwargs)

    def open(self) -> None:
        if self.is_open:
            raise SerialException("Port is already open.")
        if self._port is None:
            raise SerialException("Port must be configured before it can be used.")
        self.lidar = SimLidar(self.world, lidar_config(self._port))
        self._in.clear()
        self.is_open = True

    def close(self) -> None:
        self.is_open = False
        self.lidar = None

    def _update_dtr_state(self) -> None:
        pass  # an A1's motor line: the simulated motor always turns

    def _update_rts_state(self) -> None:
        pass

    def _update_break_state(self) -> None:
        pass

    def _reconfigure_port(self, *args, **kwargs) -> None:
        pass

    def _sensor(self) -> SimLidar:
        if not self.is_open or self.lidar is None:
            raise PortNotOpenError()
        return self.lidar

    @property
    def in_waiting(self) -> int:
        self._in += self._sensor().pop_due(self.clock())
        return len(self._in)

    def write(self, data: bytes) -> int:
        self._sensor().receive(bytes(data), self.clock())
        return len(data)

    def read(self, size: int = 1) -> bytes:
        """Up to `size` bytes, waiting at most `timeout` seconds of real time."""
        lidar = self._sensor()
        deadline = time.monotonic() + (self._timeout if self._timeout is not None else 0.0)
        while True:
            self._in += lidar.pop_due(self.clock())
            if len(self._in) >= size or time.monotonic() >= deadline:
                out = bytes(self._in[:size])
                del self._in[:size]
                return out
            time.sleep(min(POLL_S, max(0.0, deadline - time.monotonic())))

    def reset_input_buffer(self) -> None:
        self._sensor()
        self._in.clear()

    def reset_output_buffer(self) -> None:
        pass


def lidar_config(url: str) -> LidarConfig:
    """The sensor a `giraff-lidar://` URL asks for (see the module's table)."""
    parts = urllib.parse.urlsplit(url)
    if parts.scheme != SCHEME:
        raise SerialException(f"expected a {SCHEME}:// URL, got {url!r}")
    try:
        options = {k: v[-1] for k, v in urllib.parse.parse_qs(parts.query, True).items()}
        unknown = set(options) - {"rate", "samples", "imperfect", "seed", "health"}
        if unknown:
            raise ValueError(f"unknown option {sorted(unknown)[0]!r}")
        if options.get("health", "good") not in HEALTH:
            raise ValueError(f"health must be one of {', '.join(HEALTH)}")
        if options.get("imperfect", "0") not in ("0", "1"):
            raise ValueError("imperfect must be 0 or 1")
        return LidarConfig(
            rate_hz=float(options.get("rate", A1_RATE_HZ)),
            samples=int(options.get("samples", A1_SAMPLES)),
            noise=options.get("imperfect") == "1",
            seed=int(options["seed"]) if "seed" in options else None,
            health=HEALTH[options.get("health", "good")],
        )
    except ValueError as error:
        raise SerialException(f"bad {SCHEME}:// URL {url!r}: {error}") from None


def lidar_url(rate_hz: float = A1_RATE_HZ, samples: int = A1_SAMPLES,
              seed: int | None = None) -> str:  # fmt: skip
    """The in-process simulated lidar's URL; with `seed`, its range noise on."""
    options = [f"rate={rate_hz:g}", f"samples={samples}"]
    if seed is not None:
        options += ["imperfect=1", f"seed={seed}"]
    return f"{SCHEME}://?" + "&".join(options)
