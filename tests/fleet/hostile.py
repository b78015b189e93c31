"""Hostile messages for a vehicle (issue 28, "Bad input"): malformed JSON, messages the
standard's schema refuses, the wrong version, orders for another vehicle, oversized
ones, orders whose nodes are real rooms but that cannot be done, instant actions of
unknown types or with absurd parameters, floods of pause and cancel, and mixes of them.

Deterministic: the same seed gives the same messages, byte for byte. Every message is
hostile by construction and checked to be so by `would_act`, which says whether the
vehicle would accept it and might move: what it would accept is drawn again, so that a
test's "0 motion" measures the vehicle, not luck.
"""

from __future__ import annotations

import copy
import itertools
import json
import random
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from giraff_console.fleet.broker_link import MAX_MESSAGE_BYTES
from giraff_console.fleet.orders import Refusal, read_order
from giraff_console.fleet.schemas import problem
from giraff_console.fleet.topics import MAJOR, VERSION, Topic, VehicleId
from giraff_console.planning.floorplan import FloorPlan
from giraff_console.settings import MotionSettings
from tests.fleet.fleet_site import instant_action

SEED = 28
# The kinds a vehicle is sent to (it subscribes to these) ...
READ_KINDS = (Topic.ORDER, Topic.INSTANT_ACTIONS)
# ... and its own, where an impostor may publish (it must not listen).
IMPOSTOR_KINDS = (Topic.STATE, Topic.CONNECTION, Topic.FACTSHEET, Topic.VISUALIZATION)
# Instant actions that do what they say when asked in the right shape, and may move the
# robot (to or off the dock, or its estimate): a valid request is not hostile.
MOVING_ACTIONS = ("startCharging", "stopCharging")
HARMLESS_ACTIONS = ("startPause", "stopPause", "cancelOrder", "stateRequest", "factsheetRequest")
# One in this many messages is oversized (they are big: the broker and paho carry them).
OVERSIZED_ONE_IN = 500


@dataclass(frozen=True)
class Hostile:
    """One message: where it goes, its bytes, and what it is (for the figures)."""

    topic: str
    payload: bytes
    what: str


@dataclass(frozen=True)
class Site:
    """What the generator knows of the robot: who it is, its plan, where it stands."""

    vehicle: VehicleId
    plan: FloorPlan
    here: str

    @property
    def rooms(self) -> list[str]:
        return sorted(self.plan.rooms)

    @property
    def doors(self) -> list[str]:
        return sorted(door.id for door in self.plan.doors)


def hostile_messages(site: Site, kind: Topic, count: int, seed: int = SEED) -> Iterator[Hostile]:
    """`count` hostile messages on `site.vehicle`'s `kind` topic."""
    rng = random.Random(f"{seed}/{kind.value}")
    topic = site.vehicle.topic(kind)
    for number in range(count):
        if number % OVERSIZED_ONE_IN == OVERSIZED_ONE_IN - 1:
            yield Hostile(topic, _oversized(rng), "oversized")
            continue
        while True:
            what, payload = _one(rng, site, kind, number)
            if kind in IMPOSTOR_KINDS or not would_act(site, kind, payload):
                break
        yield Hostile(topic, payload, what)


def _one(rng: random.Random, site: Site, kind: Topic, number: int) -> tuple[str, bytes]:
    if kind is Topic.ORDER:
        makers = ORDER_MAKERS
    elif kind is Topic.INSTANT_ACTIONS:
        makers = INSTANT_MAKERS
    else:
        makers = IMPOSTOR_MAKERS
    name, make = rng.choice(makers)
    body = make(rng, site)
    if isinstance(body, bytes):
        return name, body
    payload = _encode(body)
    if rng.random() < 0.15:  # a mix: a second thing wrong, in the bytes
        name += "+" + (mutation := rng.choice(BYTE_MUTATIONS))[0]
        payload = mutation[1](rng, payload)
    return name, payload


# -- the oracle ---------------------------------------------------------------------------


def would_act(site: Site, kind: Topic, payload: bytes) -> bool:
    """Whether the vehicle would take this message and might move: an order it would
    accept, or an instant action that moves (or relocates) the robot when valid. The
    cheap checks first: all must pass for the vehicle to act."""
    try:
        message = json.loads(payload)
    except (ValueError, RecursionError):
        return False
    if not isinstance(message, dict):
        return False
    try:
        if str(message["version"]).split(".")[0] != MAJOR.removeprefix("v"):
            return False
        if (message["manufacturer"], message["serialNumber"]) != (
            site.vehicle.manufacturer,
            site.vehicle.serial_number,
        ):
            return False
        if kind is Topic.ORDER:
            if read_order(message, site.plan, MotionSettings().v_max).first.node_id != site.here:
                return False
        elif not any(_action_acts(site, action) for action in message["actions"]):
            return False
    except (Refusal, LookupError, TypeError, ValueError, ArithmeticError, AttributeError):
        return False  # refused, or not in the shape the schema asks (or the vehicle fails)
    try:
        return problem(kind, message) is None
    except RecursionError:
        return False


def _action_acts(site: Site, action: dict[str, Any]) -> bool:
    kind = action["actionType"]
    if kind in MOVING_ACTIONS:
        return True
    if kind != "initPosition":
        return False
    params = {
        str(item.get("key")): item.get("value")
        for item in action.get("actionParameters") or ()
        if isinstance(item, dict)
    }
    room = params.get("lastNodeId")
    if isinstance(room, str) and room in site.plan.rooms:
        return True
    x, y = params.get("x"), params.get("y")
    numbers = all(isinstance(v, int | float) and not isinstance(v, bool) for v in (x, y))
    # Anywhere within the building's reach might be a room's point: not absurd.
    return numbers and all(abs(v) < 1e3 for v in (x, y))  # type: ignore[operator]


# -- messages in the right shape, to spoil ------------------------------------------------


def _header(rng: random.Random, site: Site) -> dict[str, Any]:
    return {
        "headerId": rng.randrange(0, 10**6),
        "timestamp": "2025-03-11T11:40:03.120Z",
        "version": VERSION,
        "manufacturer": site.vehicle.manufacturer,
        "serialNumber": site.vehicle.serial_number,
    }


def _node(room: str, sequence: int, released: bool = True) -> dict[str, Any]:
    return {"nodeId": room, "sequenceId": sequence, "released": released, "actions": []}


def _edge(a: str, b: str, sequence: int, released: bool = True) -> dict[str, Any]:
    return {
        "edgeId": f"{a}>{b}",
        "sequenceId": sequence,
        "released": released,
        "startNodeId": a,
        "endNodeId": b,
        "actions": [],
    }


def _order(rng: random.Random, site: Site, rooms: list[str], first: int = 0) -> dict[str, Any]:
    return {
        **_header(rng, site),
        "orderId": f"hostile-{rng.randrange(10**6)}",
        "orderUpdateId": 0,
        "nodes": [_node(room, first + 2 * i) for i, room in enumerate(rooms)],
        "edges": [
            _edge(a, b, first + 2 * i + 1) for i, (a, b) in enumerate(itertools.pairwise(rooms))
        ],
    }


def _near_order(rng: random.Random, site: Site) -> dict[str, Any]:
    """An order the vehicle would take: from where it stands to a room or two: the
    base that every order maker spoils."""
    others = [room for room in site.rooms if room != site.here]
    return _order(rng, site, [site.here, *rng.sample(others, rng.randint(1, 3))])


def _action(action_type: str, action_id: str, **parameters: Any) -> dict[str, Any]:
    return instant_action(action_type, action_id, parameters)


def _instant(rng: random.Random, site: Site, actions: list[dict[str, Any]]) -> dict[str, Any]:
    return {**_header(rng, site), "actions": actions}


# -- malformed JSON -----------------------------------------------------------------------


def _truncated(rng: random.Random, site: Site) -> bytes:
    payload = json.dumps(_near_order(rng, site)).encode()
    return payload[: rng.randrange(0, len(payload))]


def _binary(rng: random.Random, site: Site) -> bytes:
    return rng.randbytes(rng.randrange(0, 2048))


def _bad_utf8(rng: random.Random, site: Site) -> bytes:
    payload = bytearray(json.dumps(_near_order(rng, site)).encode())
    for _ in range(rng.randint(1, 4)):
        payload.insert(rng.randrange(len(payload)), rng.choice((0xFF, 0xC3, 0x80, 0xED, 0xFE)))
    return bytes(payload)


def _huge_number(rng: random.Random, site: Site) -> bytes:
    body = json.dumps(_near_order(rng, site))
    digits = rng.choice(("9" * 5000, "1e999999", "-1e400", "1" * 4000, "0." + "0" * 4000 + "1"))
    field = rng.choice(("headerId", "orderUpdateId", "sequenceId"))
    return body.replace(f'"{field}": ', f'"{field}": {digits}, "x{field}": ', 1).encode()


def _deep(rng: random.Random, site: Site) -> bytes:
    depth = rng.choice((100_000, 5_000, 1_100, 990))
    opener, closer = rng.choice((("[", "]"), ('{"a":', "}")))
    if opener == "{":  # five times the bytes: fewer levels, under the size limit
        depth = min(depth, 40_000)
    return (opener * depth + "1" + closer * depth).encode()


def _non_finite(rng: random.Random, site: Site) -> bytes:
    body = json.dumps(_near_order(rng, site))
    literal = rng.choice(("NaN", "Infinity", "-Infinity"))
    field = rng.choice(("headerId", "orderUpdateId", "sequenceId"))
    return body.replace(f'"{field}": ', f'"{field}": {literal}, "x{field}": ', 1).encode()


def _duplicate_keys(rng: random.Random, site: Site) -> bytes:
    """The last of a key's values is the one json reads: another vehicle's, here."""
    body = json.dumps(_near_order(rng, site))
    key, value = rng.choice((("serialNumber", "g99"), ("version", "3.0.0"), ("nodes", "[]")))
    value = json.dumps(value) if key != "nodes" else "{}"
    return (body[:-1] + f', "{key}": {value}}}').encode()


def _not_an_object(rng: random.Random, site: Site) -> bytes:
    return rng.choice((b"", b" ", b"null", b"[]", b"123", b'"order"', b"true", b"\xef\xbb\xbf{}"))


def _utf16(rng: random.Random, site: Site) -> bytes:
    """Valid JSON in another encoding (json reads UTF-16 too) of a spoiled order."""
    order = _near_order(rng, site)
    order["nodes"][0]["nodeId"] = "the-moon"
    return json.dumps(order).encode(rng.choice(("utf-16", "utf-32")))


MALFORMED: list[tuple[str, Callable[[random.Random, Site], Any]]] = [
    ("truncated", _truncated),
    ("binary", _binary),
    ("invalid UTF-8", _bad_utf8),
    ("huge number", _huge_number),
    ("deep nesting", _deep),
    ("NaN/Infinity", _non_finite),
    ("duplicate keys", _duplicate_keys),
    ("not an object", _not_an_object),
    ("UTF-16/32", _utf16),
]


# -- valid JSON, wrong by the schema or for someone else ----------------------------------

ODD_VALUES: tuple[Any, ...] = (
    None, True, False, 0, -1, 2**63, 10**400, 1.5, -0.0, 1e308, "", "x" * 300, "dock",
    [], [1, "a"], {}, {"a": {"b": []}}, "2.1.0", "NaN",
)  # fmt: skip


def _odd(rng: random.Random) -> Any:
    """One of ODD_VALUES, a copy: a later spoiling must not change the table."""
    return copy.deepcopy(rng.choice(ODD_VALUES))


def _walk(value: Any) -> list[tuple[Any, Any]]:
    """Every (container, key or index) in a JSON value."""
    places: list[tuple[Any, Any]] = []
    if isinstance(value, dict):
        for key, inner in value.items():
            places.append((value, key))
            places.extend(_walk(inner))
    elif isinstance(value, list):
        for index, inner in enumerate(value):
            places.append((value, index))
            places.extend(_walk(inner))
    return places


def _spoil(rng: random.Random, body: dict[str, Any], times: int = 1) -> dict[str, Any]:
    """Drop a key, or give it a value of the wrong type, `times` over."""
    for _ in range(times):
        places = _walk(body)
        if not places:
            break
        container, key = rng.choice(places)
        if isinstance(container, dict) and rng.random() < 0.4:
            del container[key]
        else:
            container[key] = _odd(rng)
    return body


def _schema_order(rng: random.Random, site: Site) -> dict[str, Any]:
    return _spoil(rng, _near_order(rng, site), rng.randint(1, 3))


def _schema_instant(rng: random.Random, site: Site) -> dict[str, Any]:
    return _spoil(rng, _instant(rng, site, [_action("startPause", "p")]), rng.randint(1, 3))


def _wrong_version(body: dict[str, Any], rng: random.Random) -> dict[str, Any]:
    body["version"] = rng.choice(("1.1.0", "3.0.0", "1.3.2", "0.2.1", "20.1.0", "", "v2", " 2.1"))
    return body


def _someone_else(body: dict[str, Any], rng: random.Random) -> dict[str, Any]:
    field, value = rng.choice(
        (
            ("serialNumber", "g02"),
            ("serialNumber", "G01"),
            ("serialNumber", "g01 "),
            ("serialNumber", ""),
            ("manufacturer", "acme"),
            ("manufacturer", "Giraff"),
        )
    )
    body[field] = value
    return body


# -- orders of real rooms that cannot be done ---------------------------------------------


def _elsewhere(rng: random.Random, site: Site) -> dict[str, Any]:
    others = [room for room in site.rooms if room != site.here]
    return _order(rng, site, rng.sample(others, rng.randint(1, 4)))


def _unknown_nodes(rng: random.Random, site: Site) -> dict[str, Any]:
    order = _near_order(rng, site)
    node = rng.choice(order["nodes"][1:])
    moon = rng.choice(("the-moon", "DOCK", "dock ", "", "w-16", "../etc/passwd", "é" * 50))
    for edge in order["edges"]:
        for end in ("startNodeId", "endNodeId"):
            if edge[end] == node["nodeId"]:
                edge[end] = moon
    node["nodeId"] = moon
    return order


def _thousands(rng: random.Random, site: Site) -> dict[str, Any]:
    rooms = [site.here] + [rng.choice(site.rooms) for _ in range(rng.randint(101, 900))]
    return _order(rng, site, rooms)


def _sequence_ids(rng: random.Random, site: Site) -> dict[str, Any]:
    order = _near_order(rng, site)
    items = order["nodes"] + order["edges"]
    for item in rng.sample(items, rng.randint(1, len(items))):
        item["sequenceId"] = rng.choice((-1, -(2**63), 2**63, 10**30, 10**4000, 0, 7))
    return order


def _crossing(rng: random.Random, site: Site) -> dict[str, Any]:
    """Edges that join the wrong nodes, or whose sequence is not between them."""
    order = _near_order(rng, site)
    edge = rng.choice(order["edges"])
    how = rng.randrange(3)
    if how == 0:
        edge["startNodeId"], edge["endNodeId"] = edge["endNodeId"], edge["startNodeId"]
    elif how == 1:
        edge["endNodeId"] = rng.choice(site.rooms)
        if edge["endNodeId"] == order["nodes"][-1]["nodeId"]:
            edge["startNodeId"] = "the-moon"
    else:
        edge["sequenceId"] = order["nodes"][-1]["sequenceId"] + 1
    return order


def _shape(rng: random.Random, site: Site) -> dict[str, Any]:
    """Released after the horizon, an unreleased first node, too few or many edges, a
    released edge before an unreleased node, no nodes."""
    order = _near_order(rng, site)
    how = rng.randrange(6)
    if how == 0:
        order["nodes"][0]["released"] = False
    elif how == 1 and len(order["nodes"]) > 2:
        order["nodes"][1]["released"] = False
        order["edges"][0]["released"] = False
    elif how == 2:
        order["edges"].append(_edge(site.here, site.here, 99))
    elif how == 3:
        order["edges"].pop()
    elif how == 4:
        order["nodes"], order["edges"] = [], []
    else:
        order["nodes"][-1]["released"] = False
    return order


def _doors(rng: random.Random, site: Site) -> dict[str, Any]:
    """A door where the robot cannot be: first, last, or between the wrong rooms."""
    door = rng.choice(site.doors)
    how = rng.randrange(3)
    if how == 0:
        rooms = [door, site.here]
    elif how == 1:
        rooms = [site.here, door]
    else:
        rooms = [site.here, door, rng.choice(site.rooms)]
    return _order(rng, site, rooms)


def _node_actions(rng: random.Random, site: Site) -> dict[str, Any]:
    order = _near_order(rng, site)
    target = rng.choice(order["nodes"] + order["edges"])
    target["actions"] = [_action(rng.choice(("pick", "drop", "startCharging")), "a")]
    return order


def _positions(rng: random.Random, site: Site) -> dict[str, Any]:
    order = _near_order(rng, site)
    node = rng.choice(order["nodes"])
    x = rng.choice((10**400, -(10**400), 1e308, 9e15, -1e6, 1e3, 2**63))
    node["nodePosition"] = {
        "x": x,
        "y": rng.choice((0, 10**400, -1e308)),
        "mapId": rng.choice((site.plan.name, site.plan.name, "another map", "")),
    }
    return order


def _ids(rng: random.Random, site: Site) -> dict[str, Any]:
    """Long or odd ids and a huge update id, on an order that starts elsewhere."""
    order = _elsewhere(rng, site)
    order["orderId"] = rng.choice(("", "\x00", "o" * 100_000, "\u202e" * 50))
    order["orderUpdateId"] = rng.choice((0, 2**63, 10**4000))
    return order


# -- instant actions that must not move the robot ----------------------------------------


def _unknown_action(rng: random.Random, site: Site) -> dict[str, Any]:
    kind = rng.choice(("pick", "drop", "detectObject", "finePositioning", "", "x" * 5000))
    return _instant(rng, site, [_action(kind, f"u{rng.randrange(10**6)}")])


def _wrong_parameters(rng: random.Random, site: Site) -> dict[str, Any]:
    kind = rng.choice((*HARMLESS_ACTIONS, "initPosition"))
    parameters = {
        rng.choice(("x", "y", "theta", "lastNodeId", "mapId", "duration", "")): _odd(rng)
        for _ in range(rng.randint(1, 5))
    }
    action = _action(kind, f"w{rng.randrange(10**6)}", **parameters)
    if rng.random() < 0.3:
        action["actionParameters"].append(_odd(rng))  # not an object
    return _instant(rng, site, [action])


def _absurd_place(rng: random.Random, site: Site) -> dict[str, Any]:
    far = (1e308, -1e308, 10**400, -(10**400), 1e6, 9e15)
    parameters: dict[str, Any] = {
        "x": rng.choice(far),
        "y": rng.choice((*far, 0)),
        "theta": rng.choice((0, 1e308, 10**400, "north")),
        "mapId": rng.choice((site.plan.name, "another map")),
    }
    if rng.random() < 0.5:
        parameters["lastNodeId"] = rng.choice(
            ("the-moon", "", 7, ["dock"], {"room": "dock"}, None, True)
        )
    return _instant(rng, site, [_action("initPosition", f"i{rng.randrange(10**6)}", **parameters)])


def _flood(rng: random.Random, site: Site) -> dict[str, Any]:
    """Many pause, resume and cancel actions in one message (with nothing under way)."""
    actions = [
        _action(rng.choice(HARMLESS_ACTIONS[:3]), f"f{i}") for i in range(rng.randint(1, 300))
    ]
    return _instant(rng, site, actions)


def _long_ids(rng: random.Random, site: Site) -> dict[str, Any]:
    """Action ids and types of up to 200 kB, echoed back in `state`."""
    size = rng.choice((1_000, 50_000, 200_000))
    return _instant(rng, site, [_action(rng.choice(("startPause", "x" * size)), "i" * size)])


def _version_of(make: Callable[[random.Random, Site], dict[str, Any]]) -> Callable[..., Any]:
    return lambda rng, site: _wrong_version(make(rng, site), rng)


def _other_of(make: Callable[[random.Random, Site], dict[str, Any]]) -> Callable[..., Any]:
    return lambda rng, site: _someone_else(make(rng, site), rng)


def _charge(rng: random.Random, site: Site) -> dict[str, Any]:
    return _instant(rng, site, [_action("startCharging", f"d{rng.randrange(100)}")])


def _cancel_flood(rng: random.Random, site: Site) -> dict[str, Any]:
    return _instant(rng, site, [_action(rng.choice(HARMLESS_ACTIONS), f"c{rng.randrange(100)}")])


ORDER_MAKERS: list[tuple[str, Callable[[random.Random, Site], Any]]] = [
    *MALFORMED,
    ("schema", _schema_order),
    ("schema", _schema_order),
    ("wrong version", _version_of(_near_order)),
    ("another vehicle", _other_of(_near_order)),
    ("starts elsewhere", _elsewhere),
    ("unknown nodes", _unknown_nodes),
    ("thousands of nodes", _thousands),
    ("sequenceIds", _sequence_ids),
    ("edges crossing", _crossing),
    ("shape", _shape),
    ("doors", _doors),
    ("node actions", _node_actions),
    ("positions", _positions),
    ("ids", _ids),
]

INSTANT_MAKERS: list[tuple[str, Callable[[random.Random, Site], Any]]] = [
    *MALFORMED,
    ("schema", _schema_instant),
    ("schema", _schema_instant),
    ("wrong version", _version_of(_cancel_flood)),
    ("another vehicle", _other_of(_charge)),
    ("unknown type", _unknown_action),
    ("wrong parameters", _wrong_parameters),
    ("absurd place", _absurd_place),
    ("flood in one", _flood),
    ("pause/resume/cancel", _cancel_flood),
    ("pause/resume/cancel", _cancel_flood),
    ("long ids", _long_ids),
]  # fmt: skip


def _impostor_state(rng: random.Random, site: Site) -> dict[str, Any]:
    return _spoil(
        rng,
        {
            **_header(rng, site),
            "orderId": "taken-over",
            "orderUpdateId": 0,
            "lastNodeId": rng.choice(site.rooms),
            "driving": True,
            "operatingMode": "SERVICE",
            "errors": [],
        },
        rng.randint(0, 2),
    )


def _impostor_connection(rng: random.Random, site: Site) -> dict[str, Any]:
    state = rng.choice(("OFFLINE", "CONNECTIONBROKEN", "ONLINE", "gone"))
    return {**_header(rng, site), "connectionState": state}


IMPOSTOR_MAKERS: list[tuple[str, Callable[[random.Random, Site], Any]]] = [
    *MALFORMED,
    ("impostor state", _impostor_state),
    ("impostor connection", _impostor_connection),
    ("an order here", _near_order),  # even one the vehicle would take on its order topic
    ("pause/resume/cancel", _cancel_flood),
]


# -- byte mutations, for mixes ------------------------------------------------------------


def _flip(rng: random.Random, payload: bytes) -> bytes:
    spoilt = bytearray(payload)
    for _ in range(rng.randint(1, 8)):
        if spoilt:
            spoilt[rng.randrange(len(spoilt))] = rng.randrange(256)
    return bytes(spoilt)


def _cut(rng: random.Random, payload: bytes) -> bytes:
    return payload[: rng.randrange(len(payload) + 1)]


def _nul(rng: random.Random, payload: bytes) -> bytes:
    at = rng.randrange(len(payload) + 1)
    return payload[:at] + b"\x00" + payload[at:]


BYTE_MUTATIONS: list[tuple[str, Callable[[random.Random, bytes], bytes]]] = [
    ("bytes flipped", _flip),
    ("cut", _cut),
    ("NUL", _nul),
]


def _encode(body: dict[str, Any]) -> bytes:
    return json.dumps(body).encode()


def _oversized(rng: random.Random) -> bytes:
    """Just over the link's limit: never parsed."""
    return b'{"pad":"' + b"x" * (MAX_MESSAGE_BYTES + rng.randrange(1, 4096)) + b'"}'


def other_topics(vehicle: VehicleId) -> list[str]:
    """Topics next to the vehicle's that it must not hear (nor the broker give it)."""
    name = f"{vehicle.manufacturer}/{vehicle.serial_number}"
    return [
        f"uagv/v2/{vehicle.manufacturer}/g99/order",
        f"uagv/v1/{name}/order",
        f"uagv/v2/{vehicle.manufacturer}/{vehicle.serial_number.upper()}/instantActions",
        f"uagv/v2/{name}/order/more",
        f"uagv/v2/{name}/Order",
        f"other/v2/{name}/order",
    ]
