"""The service's data types survive the trip through JSON, and bad data fails cleanly."""

from __future__ import annotations

import dataclasses
import enum
import json
import math
import types
import typing
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
from giraff_console.service import commands as c
from giraff_console.service.console_hello import Asked
from giraff_console.service.wire import (
    Count,
    Number,
    Text,
    WireError,
    decode,
    encode,
    register,
    registered,
)

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
    with pytest.raises(WireError, match="expected bytes in base64, got other text"):
        decode({"bytes": "not base64!"})


# -- fields checked against their annotations (issue 30, item 4) ---------------------


def test_a_text_where_a_number_belongs_is_refused_naming_the_field():
    with pytest.raises(
        WireError, match=r"^Pose\.x: expected a number, got a text of 3 characters$"
    ):
        decode({"type": "Pose", "x": "1.0"})


def test_true_is_no_integer_and_no_number():
    with pytest.raises(WireError, match=r"^MotorState\.mode: expected an integer"):
        decode(wire_of(full_telemetry().state, mode=True))
    with pytest.raises(WireError, match=r"^Pose\.x: expected a number, got true$"):
        decode({"type": "Pose", "x": True})


def test_an_integer_where_a_float_belongs_comes_back_a_float():
    back = decode({"type": "Pose", "x": 1})
    assert back == Pose(1.0) and type(back.x) is float  # type: ignore[attr-defined]


def test_an_integer_beyond_64_bits_is_refused():
    with pytest.raises(WireError, match=r"^Pose\.x: expected a number, got an integer of"):
        decode({"type": "Pose", "x": 10**30})


def test_a_nested_dataclass_of_another_class_is_refused():
    with pytest.raises(WireError, match=r"^Telemetry\.pose: expected a Pose, got a Battery$"):
        decode(wire_of(full_telemetry(), pose=encode(Battery(ChargeStatus.TRICKLE_CHARGING))))


def test_an_enum_of_another_class_is_refused():
    with pytest.raises(
        WireError, match=r"^Telemetry\.link: expected a LinkState \(.*\), got an enum"
    ):
        decode(wire_of(full_telemetry(), link={"enum": "PoseBasis", "value": "ODOMETRY"}))


def test_a_bad_item_of_a_tuple_is_refused_by_its_place():
    estimate = encode(full_telemetry().estimate)
    assert isinstance(estimate, dict)
    with pytest.raises(WireError, match=r"^Estimate\.seen\[1\]: expected an integer"):
        decode({**estimate, "seen": [3, "7"]})
    with pytest.raises(WireError, match=r"^Estimate\.ellipse: expected a list of 3"):
        decode({**estimate, "ellipse": [0.1, 0.2]})


def test_a_refusal_never_quotes_what_came():
    # What a client sent goes back in a refusal only as words: its kind and size.
    for junk in ("<script>x</script>", "x" * 100, "a\nb"):
        with pytest.raises(WireError) as refused:
            decode({"type": junk})
        assert junk not in str(refused.value)
        with pytest.raises(WireError) as refused:
            decode({"type": "Pose", "x": junk})
        assert junk not in str(refused.value)


def wire_of(value: object, **fields: object) -> dict[str, object]:
    """`value` as it crosses, with `fields` replaced by these wire data."""
    data = encode(value)
    assert isinstance(data, dict)
    return {**data, **fields}


# -- every request, every field -------------------------------------------------------

# A valid value of each kind of field, within every request's bounds.
VALID: dict[object, object] = {
    str: "kitchen",
    bool: True,
    int: 0,
    float: 0.5,
    Path: {"path": "/tmp/giraff.patrol.yaml"},
}


def _plain(hint: object) -> tuple[object, list[object]]:
    """The annotation without `| None` and `Annotated`, and the bounds it carried."""
    bounds: list[object] = []
    while True:
        origin, args = typing.get_origin(hint), typing.get_args(hint)
        if origin is typing.Annotated:
            hint, bounds = args[0], [*bounds, *args[1:]]
        elif origin is types.UnionType or origin is typing.Union:
            hint = next(arg for arg in args if arg is not type(None))
        else:
            return hint, bounds


def _valid(hint: object) -> object:
    plain, _ = _plain(hint)
    if typing.get_origin(plain) is tuple:
        return [_valid(typing.get_args(plain)[0])]
    if isinstance(plain, type) and issubclass(plain, enum.Enum):
        return encode(next(iter(plain)))
    if plain is str and "controller command" in str(_plain(hint)[1]):
        return "get bulk_data"
    return VALID[plain]


def _wrong(hint: object) -> list[object]:
    """JSON values that no field of this kind may take."""
    plain, _ = _plain(hint)
    if typing.get_origin(plain) in (tuple, list):
        return ["get bulk_data", 7, {"type": "Halt"}]
    if isinstance(plain, type) and issubclass(plain, enum.Enum):
        return [next(iter(plain)).name, [1, 0], {"enum": "LinkState", "value": "LOST"}]
    wrong = {
        str: [["a", "list"], 7, True, {"type": "Halt"}, {"path": "kitchen"}],
        bool: [1, "yes", ["x"], 0.0],
        int: [True, 1.5, "7", ["x"]],
        float: [True, "0.5", ["x"], {"type": "Halt"}],
        Path: ["/plain/text", ["x"], {"path": 7}],
    }
    assert plain in wrong, f"a field annotated {hint}: teach this test its wrong values"
    return wrong[plain]


def _fields(request: type[c.Request]) -> dict[str, object]:
    hints = typing.get_type_hints(request, include_extras=True)
    return {field.name: hints[field.name] for field in dataclasses.fields(request)}


def _asked(request: type[c.Request], **fields: object) -> dict[str, object]:
    """A request as a client puts it on the socket: every field valid but `fields`."""
    valid = {name: _valid(hint) for name, hint in _fields(request).items()}
    return {"type": "Asked", "number": 1,
            "request": {"type": request.__name__, **valid, **fields}}  # fmt: skip


@pytest.mark.parametrize("request_class", c.REQUESTS, ids=lambda r: r.__name__)
def test_a_request_with_every_field_valid_is_built(request_class: type[c.Request]):
    asked = decode(_asked(request_class))
    assert isinstance(asked, Asked) and type(asked.request) is request_class


@pytest.mark.parametrize("request_class", c.REQUESTS, ids=lambda r: r.__name__)
def test_each_field_of_a_request_given_a_wrong_type_is_refused_naming_it(
    request_class: type[c.Request],
):
    for name, hint in _fields(request_class).items():
        for wrong in _wrong(hint):
            with pytest.raises(WireError) as refused:
                decode(_asked(request_class, **{name: wrong}))
            message = str(refused.value)
            assert message.startswith(f"{request_class.__name__}.{name}: expected "), message


@pytest.mark.parametrize("request_class", c.REQUESTS, ids=lambda r: r.__name__)
def test_every_text_number_path_and_tuple_a_request_holds_is_bounded(
    request_class: type[c.Request],
):
    for name, hint in _fields(request_class).items():
        plain, bounds = _plain(hint)
        if plain is bool or (isinstance(plain, type) and issubclass(plain, enum.Enum)):
            continue
        assert bounds, f"{request_class.__name__}.{name} carries no bound (commands.py)"


def _out_of_bounds(bound: object, hint: object) -> list[object]:
    plain, _ = _plain(hint)
    if isinstance(bound, Text):
        long = "x" * (bound.longest + 1)
        junk = ["kitchen\n", "\x00", "\x1b[2J"] if bound.pattern is not None else []
        return [{"path": long}] if plain is Path else [long, *junk]
    if isinstance(bound, Number):
        if plain is int:
            return [int(bound.low) - 1, int(bound.high) + 1]
        return [bound.low - 1, bound.high + 1, math.nan, math.inf, -math.inf]
    assert isinstance(bound, Count)
    item = _valid(typing.get_args(plain)[0])
    return [[item] * (bound.most + 1)] + ([[]] if bound.fewest else [])


@pytest.mark.parametrize("request_class", c.REQUESTS, ids=lambda r: r.__name__)
def test_each_field_of_a_request_out_of_its_bounds_is_refused_saying_them(
    request_class: type[c.Request],
):
    for name, hint in _fields(request_class).items():
        for bound in _plain(hint)[1]:
            for bad in _out_of_bounds(bound, hint):
                # The line a client writes: NaN and Infinity as json writes them.
                line = json.dumps(_asked(request_class, **{name: bad}))
                with pytest.raises(WireError) as refused:
                    decode(json.loads(line))
                where = f"{request_class.__name__}.{name}: expected {bound.what}"  # type: ignore[attr-defined]
                assert str(refused.value).startswith(where), str(refused.value)


def test_a_name_that_a_path_or_a_shell_would_read_otherwise_is_refused():
    for name in ("a/b", "..", "living room", "kitchen;rm"):
        with pytest.raises(WireError, match=r"^Teach\.name: expected a route's name"):
            decode(_asked(c.Teach, name=name))


def test_a_patrol_may_be_given_by_its_file_but_no_other_path():
    assert decode(_asked(c.RunPatrol, name="/home/nurse/night.patrol.yaml"))
    with pytest.raises(WireError, match=r"^RunPatrol\.name: expected a patrol's name"):
        decode(_asked(c.RunPatrol, name="../../etc/passwd"))


def test_a_request_where_another_message_belongs_is_refused():
    with pytest.raises(WireError, match=r"^Asked\.request: expected a Request, got a Telemetry$"):
        decode({"type": "Asked", "number": 1, "request": encode(full_telemetry())})
