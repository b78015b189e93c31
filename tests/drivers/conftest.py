"""What the driver clients' tests share: the ports they open, closed afterwards."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

from tests.drivers.wire import RawPort


@pytest.fixture
def ports() -> Iterator[Callable[[str], RawPort]]:
    opened: list[RawPort] = []

    def open_port(path: str) -> RawPort:
        port = RawPort.open(path)
        opened.append(port)
        return port

    yield open_port
    for port in opened:
        port.close()
