"""What the fleet tests share: a real broker on 127.0.0.1, stopped afterwards."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from giraff_console.fleet.broker_link import Broker as BrokerAddress
from giraff_console.fleet.master import FleetMaster
from tests.fleet.broker import Broker
from tests.fleet.fake_vehicle import FakeVehicle

UP_S = 5.0


@pytest.fixture
def broker(tmp_path: Path) -> Iterator[Broker]:
    running = Broker(tmp_path).start()
    try:
        yield running
    finally:
        running.stop()


@pytest.fixture
def master(broker: Broker) -> Iterator[FleetMaster]:
    """A master control on the broker, connected."""
    with FleetMaster(BrokerAddress.parse(broker.url)) as running:
        assert running.wait_up(UP_S)
        yield running


@pytest.fixture
def vehicle(broker: Broker) -> Iterator[FakeVehicle]:
    """A stand-in vehicle in the lobby (tests/fleet/fake_vehicle.py)."""
    fake = FakeVehicle(broker.url, "giraff-01", room="lobby").start()
    yield fake
    fake.stop()


@pytest.fixture(scope="session")
def wing(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The walled wing (tests/buildings), unlike the example care home, with markers put
    up by `floorplan landmarks` as a user would: the fleet's robots drive in it."""
    from tests.buildings.console import put_up_markers
    from tests.buildings.walled_wing import walled_wing

    plan = walled_wing(tmp_path_factory.mktemp("wing"))
    markers = put_up_markers(plan)
    assert markers.placed, markers.said
    return plan
