"""A bulk_data reading made into the motor state, whatever the board or a recording says."""

from __future__ import annotations

import math

import pytest

from giraff_console.link.motor_state import MotorState
from giraff_console.protocol.errors import ProtocolError

READING = {"cang": 0.0, "cdis": 0.1, "gvr": 0.2, "cvg": 0.0, "mode": 128}


def test_a_reading_gives_the_state():
    state = MotorState.from_bulk(READING, 1.0)
    assert state.moving and state.speed == pytest.approx(0.2)


@pytest.mark.parametrize("mode", [math.inf, -math.inf, math.nan, 1.5])
def test_a_garbled_mode_is_a_protocol_error(mode):
    # `mode:F*0000807f` on the wire, or `mode:1e999` in a recorded log.
    with pytest.raises(ProtocolError, match="not a bitmask"):
        MotorState.from_bulk(READING | {"mode": mode}, 1.0)


def test_a_missing_field_is_a_protocol_error():
    with pytest.raises(ProtocolError, match="without cvg"):
        MotorState.from_bulk({k: v for k, v in READING.items() if k != "cvg"}, 1.0)
