"""The service's data types survive the trip through JSON, and bad data fails cleanly."""

from __future__ import annotations

import enum
import json
import math
from dataclasses import dataclass
from pathlib import Path

import pytest

from giraff_console.camera.shared_frame import SharedFrame
from giraff_console.link.board_probe import BoardFeatures
from giraff_console.link.exchange import Exchange
from giraff_console.link.motor_state import MotorState
from giraff_console.protocol.charger import ChargeStatus
from giraff_console.protocol.errors import BoardError, UnknownNameError
from giraff_console.robot.battery import Battery
from giraff_console.robot.deadman import Intent
from giraff_console.robot.localisation import Estimate, PoseBasis
from giraff_console.robot.mission import Progress
from giraff_console.robot.odometry import Pose
from giraff_console.robot.replay import PlaybackStatus
from giraff_console.robot.telemetry import LinkState, Telemetry
from giraff_console.service.wire import WireError, decode, encode, register, registered

register(
    SharedFrame,
    PoseBasis,
    Telemetry,
    LinkState,
    MotorState,
    Pose,
    Intent,
    PlaybackStatus,
    Progress,
    Battery,
    ChargeStatus,
    BoardFeatures,
    Estimate,
    Exchange,
    BoardError,
    UnknownNameError,
)


def cross(value: object) -> object:
    """What the other end of the socket gets: encoded, written, read and decoded."""
    return decode(json.loads(json.dumps(encode(value))))


def full_telemetry() -> Telemetry:
    return Telemetry(
        link=LinkState.CONNECTED,
        state=MotorState(
            cang=12.5,
            cdis=3.25,
            gvr=0.4,
            speed=0.35,
            cvg=0.1,
            tilt=1.5,
            imdl=10.0,
            imdr=10.5,
            mode=5,
            received_at=123.0,
            enc0=100,
            enc1=65000,
        ),
        pose=Pose(1.0, -2.0, 0.5),
        intent=Intent.FORWARD_LEFT,
        speed=0.4,
        board_r=0.25,
        autopoll=True,
        loop_hz=20.0,
        late_ms=1.5,
        playback=PlaybackStatus("session-1", 12.0, 60.0, 2.0, False),
        mission=Progress("patrol", "round 1/3", 4.0, 10.0, 12.0, Progress("kitchen", "driving")),
        battery=Battery(ChargeStatus.TRICKLE_CHARGING, 80.0, 24.1, -0.5, 30.0),
        stalk=500,
        board=BoardFeatures("2.1", True, True, True, False),
        estimate=Estimate(
            pose=Pose(1.0, -2.0, 0.5),
            odometry=Pose(1.1, -2.1, 0.45),
            covariance=((0.01, 0.0, 0.0), (0.0, 0.01, 0.0), (0.0, 0.0, 0.002)),
            sigma_m=0.1,
            sigma_heading=0.05,
            ellipse=(0.1, 0.08, 0.3),
            landmarks=True,
            found=True,
            seen=(3, 7),
            rejected=(9,),
            corrected_at=120.0,
            caster_pending=0.01,
            caster_rate=-0.02,
        ),
    )


def test_a_telemetry_with_every_field_filled_comes_back_equal():
    telemetry = full_telemetry()
    assert cross(telemetry) == telemetry


def test_fields_annotated_as_tuples_come_back_as_tuples():
    estimate = cross(full_telemetry()).estimate
    assert isinstance(estimate.covariance, tuple)
    assert all(isinstance(row, tuple) for row in estimate.covariance)
    assert isinstance(estimate.ellipse, tuple)
    assert isinstance(estimate.seen, tuple) and isinstance(estimate.rejected, tuple)


def test_a_progress_keeps_its_nested_detail():
    progress = Progress("patrol", "round 2/3", detail=Progress("stop", "driving", 1.0, 2.0))
    back = cross(progress)
    assert back == progress
    assert isinstance(back.detail, Progress)


def test_infinite_and_nan_floats_survive():
    back = cross(Pose(math.inf, -math.inf, math.nan))
    assert back.x == math.inf and back.y == -math.inf and math.isnan(back.heading)


def test_an_exchange_comes_back_with_its_value_and_error():
    exchange = Exchange(
        kind="get",
        command="get bogus",
        lines=("Unknown name: bogus",),
        value={"cang": 1.5, "mode": 3},
        error=UnknownNameError("Unknown name: bogus", "bogus"),
        sent_at=1.0,
        answered_at=1.02,
        automatic=True,
    )
    back = cross(exchange)
    assert isinstance(back, Exchange)
    # Exceptions compare by identity, so the error is checked by what it carries.
    assert back.error is not None and exchange.error is not None
    assert type(back.error) is UnknownNameError
    assert str(back.error) == str(exchange.error) == "board error: Unknown name: bogus"
    assert (back.error.line, back.error.name) == ("Unknown name: bogus", "bogus")
    assert back.lines == ("Unknown name: bogus",)
    assert back == Exchange(**{**vars(exchange), "error": back.error})


def test_an_exchange_without_error_comes_back_equal():
    exchange = Exchange("set", "set p 1", (), 1, None, 2.0, 2.01)
    assert cross(exchange) == exchange


def test_a_dict_whose_keys_look_like_tags_comes_back_a_dict():
    value = {"type": "Pose", "enum": 1, "dict": {"path": "x"}}
    assert cross(value) == value


def test_a_path_comes_back_a_path():
    assert cross(Path("/tmp/robot.sock")) == Path("/tmp/robot.sock")


def test_an_unknown_type_is_a_wire_error():
    with pytest.raises(WireError, match="unknown type 'Foo'"):
        decode({"type": "Foo", "x": 1})


def test_an_extra_field_is_a_wire_error():
    with pytest.raises(WireError, match="Pose: unknown field 'z'"):
        decode({"type": "Pose", "x": 1.0, "z": 2.0})


def test_a_missing_field_is_a_wire_error():
    with pytest.raises(WireError, match="PlaybackStatus: missing field 'paused'"):
        decode({"type": "PlaybackStatus", "name": "a", "position": 0, "duration": 1, "speed": 1})


def test_a_field_with_a_default_may_be_left_out():
    assert decode({"type": "Pose", "x": 1.0}) == Pose(1.0)


def test_an_unknown_enum_member_is_a_wire_error():
    with pytest.raises(WireError, match="LinkState has no member 'GONE'"):
        decode({"enum": "LinkState", "value": "GONE"})


@dataclass(frozen=True)
class Unregistered:
    x: int


class Colour(enum.Enum):
    RED = 1


def test_an_unregistered_dataclass_is_a_wire_error_naming_it():
    with pytest.raises(WireError, match="Unregistered is not registered"):
        encode(Unregistered(1))


def test_an_unregistered_dataclass_nested_in_a_registered_one_is_a_wire_error():
    with pytest.raises(WireError, match="Unregistered is not registered"):
        encode(Progress("a", "b", detail=Unregistered(1)))  # type: ignore[arg-type]


def test_an_unregistered_enum_is_a_wire_error():
    with pytest.raises(WireError, match="Colour is not registered"):
        encode(Colour.RED)


def test_a_value_of_no_known_kind_is_a_wire_error():
    with pytest.raises(WireError, match="cannot put a set"):
        encode({1, 2})


def test_registered_finds_a_class_by_name():
    assert registered("Telemetry") is Telemetry
    with pytest.raises(WireError, match="unknown type 'Nothing'"):
        registered("Nothing")


def test_two_classes_of_one_name_cannot_both_be_registered():
    @dataclass(frozen=True)
    class Pose:  # not robot.odometry's
        x: float

    with pytest.raises(ValueError, match="two classes named 'Pose'"):
        register(Pose)


def test_a_shared_camera_frame_comes_back_with_its_jpeg_bytes():
    frame = SharedFrame(bytes(range(256)) * 4, "synthetic", (800, 600), 9.5, 134, (16,))
    assert cross(frame) == frame


def test_bytes_that_are_not_base64_are_a_wire_error():
    with pytest.raises(WireError, match="bytes that are not base64"):
        decode({"bytes": "not base64!"})
