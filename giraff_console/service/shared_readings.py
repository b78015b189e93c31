"""Readings that a later board resets when they are read, shared out between readers.

On later firmware `imdl` and `imdr` are the wheels' travel since the previous `get
bulk_data`: a read resets them (wire-facts, "Later firmware"). With two programs on one
board, the console's control loop and one on the virtual port (§4.5), each read takes
the travel since the other's: the daemon polls twenty times a second, so a program that
reads every 0.3 s would see a sixth of what the wheels did.

So each reader other than the daemon keeps what the other reads took from it: a
`SharedReadings` taps every exchange on the loop's link, adds what each read of
bulk_data that was not its reader's own carried to its reader's pending sums, and hands
its reader, on its own read, the board's fresh values plus the pending ones, which
start again from zero. Over any run, every reader's values then add up to all the
board ever reported, which is the wheels' true travel.

The daemon needs nothing of this: the loop's odometry feed already takes every read of
bulk_data on its link, the loop's own polls and anyone else's (robot/odometry_feed.py,
`watch`), the virtual port's included.

Boards whose `imdl`/`imdr` are totals (the thesis's) are read by all alike: the
readings pass through unchanged.
"""

from __future__ import annotations

import contextlib
import math
import threading
from collections.abc import Callable, Iterator, Mapping

from giraff_console.link.exchange import Exchange
from giraff_console.protocol.codec import decode_value, encode_float, encode_int, format_number
from giraff_console.protocol.errors import ProtocolError

# What a later board resets on each read of bulk_data (wire-facts: the ROS 2 driver adds
# both up on every read, the ROS 1 driver calls them "incremental move distance").
RESET_ON_READ = ("imdl", "imdr")
BULK_DATA = "get bulk_data"


class SharedReadings:
    """One reader's share of the board's reset-on-read readings; thread-safe.

    `increments` says whether the board's `imdl`/`imdr` are increments now (how the
    console reads them, found out after each connection); it is asked on the loop's
    thread, where the exchanges come.
    """

    def __init__(self, increments: Callable[[], bool]) -> None:
        self._increments = increments
        self._lock = threading.Lock()
        self._pending = _nothing()
        # Set while the reader's own read is under way: that one is not another's.
        self._own = False

    def tap(self, event: object) -> None:
        """A control-loop listener: every exchange on the link, whoever sent it."""
        if not isinstance(event, Exchange):
            return
        values = _bulk_values(event)
        if values is None:
            return
        with self._lock:
            if self._own or not self._increments():
                return
            for name in RESET_ON_READ:
                self._pending[name] += values.get(name, 0.0)

    @contextlib.contextmanager
    def own_read(self) -> Iterator[None]:
        """The reader's own read goes on inside this: the tap leaves it out."""
        with self._lock:
            self._own = True
        try:
            yield
        finally:
            with self._lock:
                self._own = False

    def share(self, exchange: Exchange) -> tuple[str, ...]:
        """The reply lines for the reader's own read `exchange`: on a board that resets
        `imdl`/`imdr`, its fresh values plus what other reads took since the reader's
        last, which are then its; any other reply as it came."""
        if _bulk_values(exchange) is None or len(exchange.lines) != 1:
            return exchange.lines
        with self._lock:
            pending, self._pending = self._pending, _nothing()
            if not self._increments():
                return exchange.lines  # totals: every reader reads them alike
        return (add_to_list(exchange.lines[0], pending),)

    def forget(self) -> None:
        """The reader starts again from now (a program opened the port: to it the board
        just powered up, its odometers at zero)."""
        with self._lock:
            self._pending = _nothing()

    @property
    def pending(self) -> dict[str, float]:
        """What other reads took from the reader since its last read (for tests)."""
        with self._lock:
            return dict(self._pending)


def _nothing() -> dict[str, float]:
    return dict.fromkeys(RESET_ON_READ, 0.0)


def _bulk_values(exchange: Exchange) -> dict[str, float] | None:
    """`imdl`/`imdr` as a read of bulk_data that succeeded carried them; None for any
    other exchange. A read that failed may have reset them too, but what it carried is
    lost to every reader alike."""
    if exchange.kind != "get" or exchange.command != BULK_DATA or exchange.error is not None:
        return None
    if not isinstance(exchange.value, dict):
        return None
    values: dict[str, float] = {}
    for name in RESET_ON_READ:
        value = exchange.value.get(name)
        if isinstance(value, int | float) and math.isfinite(value):
            values[name] = float(value)
    return values


def add_to_list(line: str, extra: Mapping[str, float]) -> str:
    """A `name:value,...` reply line with `extra` added to the named values, each
    re-encoded as the board wrote it (`F*`, `I*` or plain ASCII, hex in the board's
    case); every other field, and a trailing comma, as it came."""
    items = line.split(",")
    for index, item in enumerate(items):
        name, colon, text = item.partition(":")
        more = extra.get(name.strip(), 0.0)
        if not colon or more == 0.0:
            continue
        try:
            value = decode_value(text)
        except ProtocolError:
            continue  # a garbled field is passed on as it came
        items[index] = f"{name}:{_encode_like(text.strip(), value + more)}"
    return ",".join(items)


def _encode_like(text: str, value: float) -> str:
    """`value` in the encoding of `text`, a value as the board wrote it."""
    if text.startswith("F*"):
        encoded = encode_float(value)
    elif text.startswith("I*"):
        encoded = encode_int(round(value))
    else:
        return format_number(value)
    # Both hex cases occur on real boards (wire-facts): answer in the board's own.
    upper = text[2:] != text[2:].lower()
    return encoded[:2] + encoded[2:].upper() if upper else encoded
