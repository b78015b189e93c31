"""The service's data types as JSON values, and back: the same types on both sides.

Design.md wants the daemon and the front ends to share data types (Dolphie), so what
crosses the socket is the dataclasses themselves, tagged by class name:

- a dataclass: `{"type": "Telemetry", "link": ..., ...}`, one key per `__init__` field;
- an enum member: `{"enum": "LinkState", "value": "CONNECTED"}` (by name: some values,
  such as Intent's, are tuples that JSON would not give back);
- an exception (`Exchange.error` carries a GiraffError): `{"error": "BoardError",
  "message": str(error), "attrs": {...}}`, its instance attributes beside its message;
- a `pathlib.Path`: `{"path": "/the/path"}`;
- bytes (a camera frame's JPEG): `{"bytes": "<base64>"}`;
- a tuple or a list: a list; a dataclass field annotated as a tuple comes back a tuple;
- a dict with str keys: itself, unless one of its keys is a tag above, in which case
  it is wrapped as `{"dict": {...}}` so that it cannot be mistaken for one.

Every dataclass, enum and exception class that crosses must be registered: a name on
the wire picks the class to build, so only the classes meant to cross can be built,
and one that was forgotten fails loudly on the sending side, not as a puzzle on the
other.

What comes in is checked against the fields' annotations before any class is built
(issue 30, item 4): a str where a str is annotated, an int (never a bool) where an int
is, an enum's member by name, a tuple of the annotated length and element types, a
nested dataclass of the annotated class or a subclass, and so on down. A field may also
carry bounds (`Annotated[str, Text(...)]`, `Number`, `Count`, below): the requests that
clients send say so (service/commands.py), so that nothing out of the robot's range
reaches the service. Whatever the data, decoding raises WireError, never anything else
(but RecursionError for nesting deeper than the stack, which the transport turns into
its own refusal), and its message names the class, the field and what was expected,
and describes what came without quoting it: the refusal goes back to a client, which
must see no Python text of any kind.

Floats inf, -inf and nan pass through where a field is a bare float: `json.dumps`
(allow_nan, its default) writes them as Infinity and NaN, which are not JSON but which
`json.loads` reads back. Both ends are this module, so that is enough; a gvr at vg = 1
is infinite (link/motor_state.py). A `Number` bound lets no such float through.
"""

from __future__ import annotations

import base64
import binascii
import dataclasses
import enum
import functools
import math
import re
import types
import typing
from collections.abc import Callable, Sized
from pathlib import Path
from typing import Any

from giraff_console.service.wire_error import WireError

_TAGS = frozenset({"type", "enum", "error", "path", "dict", "bytes"})
# Integers cross as 64-bit values: a longer one is nothing the robot counts, and the
# JSON writer refuses one past 4300 digits, which would end the connection that echoed it.
_INT_LIMIT = 2**63
# A class name is echoed in a refusal only when it looks like one: anything else a
# client sent stays out of the reply.
_CLASS_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,63}\Z")

_registry: dict[str, type] = {}


def register(*types_: type) -> None:
    """Allow these dataclasses, enums and exception classes to cross, by class name.

    Registering a class twice is harmless; two different classes of the same name
    cannot both cross (the name alone would not say which to build)."""
    for cls in types_:
        if not isinstance(cls, type) or not (
            dataclasses.is_dataclass(cls)
            or issubclass(cls, enum.Enum)
            or issubclass(cls, BaseException)
        ):
            raise TypeError(f"only dataclasses, enums and exceptions can cross: {cls!r}")
        known = _registry.get(cls.__name__)
        if known is not None and known is not cls:
            raise ValueError(
                f"two classes named {cls.__name__!r}: {known.__module__} and {cls.__module__}"
            )
        _registry[cls.__name__] = cls


def registered(name: object) -> type:
    """The class registered under this name; WireError if there is none."""
    cls = _registry.get(name) if isinstance(name, str) else None
    if cls is None:
        raise WireError(f"unknown type {_name_shown(name)}")
    return cls


def _check_registered(cls: type) -> str:
    if _registry.get(cls.__name__) is not cls:
        raise WireError(f"{cls.__module__}.{cls.__qualname__} is not registered to cross")
    return cls.__name__


# -- bounds a field may carry -------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Text:
    """A str (or a Path, by its text) of at most `longest` characters, all matching
    `pattern` when one is given; `what` says it in a refusal ("a room's id (…)")."""

    what: str
    longest: int
    pattern: re.Pattern[str] | None = None

    def holds(self, value: object) -> bool:
        text = str(value) if isinstance(value, Path) else value
        return (
            isinstance(text, str)
            and len(text) <= self.longest
            and (self.pattern is None or self.pattern.fullmatch(text) is not None)
        )


@dataclasses.dataclass(frozen=True)
class Number:
    """An int or a float from `low` to `high` (so finite); `what` says it in a refusal."""

    what: str
    low: float
    high: float

    def holds(self, value: object) -> bool:
        return isinstance(value, int | float) and self.low <= value <= self.high  # nan fails


@dataclasses.dataclass(frozen=True)
class Count:
    """A tuple or a list of `fewest` to `most` items; `what` says it in a refusal."""

    what: str
    most: int
    fewest: int = 0

    def holds(self, value: object) -> bool:
        return isinstance(value, Sized) and self.fewest <= len(value) <= self.most


Bound: typing.TypeAlias = Text | Number | Count


# -- putting values on the wire -----------------------------------------------------------


def encode(value: object) -> object:
    """The value as plain JSON data: dicts, lists, str, int, float, bool and None."""
    # Enums first: an IntEnum or a StrEnum is an int or a str as well.
    if isinstance(value, enum.Enum):
        return {"enum": _check_registered(type(value)), "value": value.name}
    if value is None or isinstance(value, str | int | float):  # bool is an int
        return value
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        data: dict[str, object] = {"type": _check_registered(type(value))}
        for field in dataclasses.fields(value):
            if field.init:
                data[field.name] = encode(getattr(value, field.name))
        return data
    if isinstance(value, Path):
        return {"path": str(value)}
    if isinstance(value, bytes):
        return {"bytes": base64.b64encode(value).decode("ascii")}
    if isinstance(value, tuple | list):
        return [encode(item) for item in value]
    if isinstance(value, dict):
        return _encode_dict(value)
    if isinstance(value, BaseException):
        return {
            "error": _check_registered(type(value)),
            "message": str(value),
            "attrs": _encode_dict(vars(value)),
        }
    raise WireError(f"cannot put a {type(value).__qualname__} on the wire: {value!r:.80}")


def _encode_dict(value: dict[Any, object]) -> dict[str, object]:
    encoded: dict[str, object] = {}
    for key, item in value.items():
        if not isinstance(key, str):
            raise WireError(f"a dict key on the wire must be a str, not {key!r:.40}")
        encoded[key] = encode(item)
    return {"dict": encoded} if _TAGS.intersection(encoded) else encoded


# -- building them again ------------------------------------------------------------------


def decode(data: object) -> object:
    """The value that `encode` turned into `data`; WireError if it cannot be built.

    Where nothing says what to expect (a message as a whole, a dict's values, an
    error's attributes), the tags say what to build; a dataclass's fields are then
    checked against their annotations."""
    if isinstance(data, list):
        return [decode(item) for item in data]
    if not isinstance(data, dict):
        return data
    if "type" in data:
        cls = registered(data["type"])
        if not dataclasses.is_dataclass(cls):
            raise WireError(f"{cls.__name__} is not a dataclass")
        return _build(cls, data)
    if "enum" in data:
        return _decode_enum(data, "a value")
    if "error" in data:
        return _decode_error(data, "a value")
    if "path" in data:
        return _decode_path(data, "a value")
    if "bytes" in data:
        return _decode_bytes(data, "a value")
    return {key: decode(item) for key, item in _unwrapped(data, "a value").items()}


def _unwrapped(data: dict[str, object], where: str) -> dict[str, object]:
    """A dict's own items: those of `{"dict": {...}}`, which wraps one whose keys look
    like tags (see `_encode_dict`)."""
    if "dict" not in data:
        return data
    inner = data["dict"]
    if len(data) != 1 or not isinstance(inner, dict):
        raise WireError(f"{where}: expected a wrapped dict, got {_got(data)}")
    return inner


def _build(cls: type, data: dict[str, object]) -> object:
    """An instance of the dataclass `cls` from its tagged fields, each checked."""
    plan = _plan(cls)
    kwargs: dict[str, object] = {}
    for key, item in data.items():
        if key == "type":
            continue
        field = plan.fields.get(key)
        if field is None:
            extra = [_name_shown(k) for k in data if k != "type" and k not in plan.fields]
            raise WireError(f"{cls.__name__}: unknown field {', '.join(extra[:3])}")
        kwargs[key] = field.rule.decode(item, field.where)
    if not kwargs.keys() >= plan.required:
        missing = [name for name in plan.order if name in plan.required and name not in kwargs]
        raise WireError(f"{cls.__name__}: missing field {', '.join(map(repr, missing))}")
    try:
        return cls(**kwargs)
    except (TypeError, ValueError):  # a __post_init__ that refuses the values together
        raise WireError(f"{cls.__name__}: fields that do not make a {cls.__name__}") from None


@dataclasses.dataclass(frozen=True)
class _Rule:
    """How one annotation's values are built: `decode(data, where)` checks and builds
    (`where` names the field for the refusal); `kinds` are the shapes of JSON data it
    may take (see `_kind`), for a union to choose by; `expected` says it for a refusal."""

    decode: Callable[[object, str], object]
    kinds: frozenset[str]
    expected: str


@dataclasses.dataclass(frozen=True)
class _Field:
    rule: _Rule
    where: str  # "Go.room"


@dataclasses.dataclass(frozen=True)
class _Plan:
    fields: dict[str, _Field]
    required: frozenset[str]
    order: tuple[str, ...]


@functools.cache
def _plan(cls: type) -> _Plan:
    """How the dataclass `cls` is built: its `__init__` fields' rules, from annotations
    resolved once. The project's dataclasses use `from __future__ import annotations`,
    so the annotations are strings, which get_type_hints resolves in the class's
    module (include_extras keeps the bounds of `Annotated`)."""
    try:
        hints = typing.get_type_hints(cls, include_extras=True)
    except Exception as error:  # a name that only exists under TYPE_CHECKING
        # Said without Python's words, which a client that named the class would see.
        raise WireError(f"cannot read {cls.__qualname__}'s field types") from error
    fields = [field for field in dataclasses.fields(cls) if field.init]
    return _Plan(
        fields={
            f.name: _Field(_rule(hints.get(f.name, Any)), f"{cls.__name__}.{f.name}")
            for f in fields
        },
        required=frozenset(
            f.name
            for f in fields
            if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        ),
        order=tuple(f.name for f in fields),
    )


_ANY = frozenset({"null", "bool", "int", "float", "str", "list", "dict", *_TAGS})


def _kind(data: object) -> str:
    """The shape of JSON data, as rules and unions tell them apart: null, bool, int,
    float, str, list, dict, or the tag of a tagged dict (type, enum, error, path, bytes)."""
    kind = _PLAIN_KINDS.get(type(data))
    if kind is not None:
        return kind
    for tag in ("type", "enum", "error", "path", "bytes"):  # only a dict is left
        if tag in data:  # type: ignore[operator]
            return tag
    return "dict"


# What json.loads gives, but dicts (their tags tell them apart).
_PLAIN_KINDS = {type(None): "null", bool: "bool", int: "int", float: "float", str: "str",
                list: "list"}  # fmt: skip


def _refuse(where: str, expected: str, data: object, why: str = "") -> typing.NoReturn:
    raise WireError(f"{where}: expected {expected}, got {_got(data)}{why}")


@functools.cache
def _rule(hint: object) -> _Rule:
    """The rule for values annotated `hint`, made once for each annotation."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is typing.Annotated:
        return _bounded(_rule(args[0]), [bound for bound in args[1:] if isinstance(bound, Bound)])
    if origin is typing.Union or origin is types.UnionType:
        return _union(tuple(_rule(member) for member in args))
    if hint is type(None) or hint is None:
        return _Rule(_exactly(type(None), "null"), frozenset({"null"}), "nothing (null)")
    if hint is bool:
        return _Rule(_exactly(bool, "true or false"), frozenset({"bool"}), "true or false")
    if hint is int:
        return _Rule(_integer, frozenset({"int"}), "an integer")
    if hint is float:
        return _Rule(_float, frozenset({"int", "float"}), "a number")
    if hint is str:
        return _Rule(_exactly(str, "a text"), frozenset({"str"}), "a text")
    if hint is bytes:
        return _Rule(_decode_bytes, frozenset({"bytes"}), "bytes")
    if hint is Path:
        return _Rule(_decode_path, frozenset({"path"}), "a path")
    if origin is typing.Literal:
        return _literal(args)
    if origin is tuple and len(args) == 2 and args[1] is Ellipsis:
        return _sequence(_rule(args[0]), tuple)
    if origin is tuple and args:
        return _fixed_tuple(tuple(_rule(arg) for arg in args))
    if origin is list and args:
        return _sequence(_rule(args[0]), list)
    if origin is dict and len(args) == 2 and args[0] is str:
        return _mapping(_rule(args[1]))
    if hint is tuple or hint is list or origin in (tuple, list):
        container = tuple if (origin or hint) is tuple else list
        return _sequence(_rule(Any), container)
    if isinstance(hint, type) and issubclass(hint, enum.Enum):
        return _enum_rule(hint)
    if isinstance(hint, type) and issubclass(hint, BaseException):
        return _Rule(functools.partial(_decode_error, base=hint), frozenset({"error"}),
                     "an error the robot reports")  # fmt: skip
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        return _dataclass_rule(hint)
    # Any, object, and what no rule knows: built as the tags say.
    return _Rule(lambda data, where: decode(data), _ANY, "a value")


def _exactly(cls: type, expected: str) -> Callable[[object, str], object]:
    def check(data: object, where: str) -> object:
        if type(data) is not cls:  # a bool is an int, but true is no count
            _refuse(where, expected, data)
        return data

    return check


def _integer(data: object, where: str) -> int:
    if type(data) is not int or not -_INT_LIMIT <= data < _INT_LIMIT:
        _refuse(where, "an integer (64 bits)", data)
    return data


def _float(data: object, where: str) -> float:
    if type(data) is float:
        return data
    if type(data) is int and -_INT_LIMIT <= data < _INT_LIMIT:
        return float(data)
    _refuse(where, "a number", data)


def _literal(values: tuple[object, ...]) -> _Rule:
    shown = " or ".join(repr(value) for value in values)

    def check(data: object, where: str) -> object:
        if not any(type(data) is type(value) and data == value for value in values):
            _refuse(where, shown, data)
        return data

    return _Rule(check, frozenset(_kind(value) for value in values), shown)


def _bounded(inner: _Rule, bounds: list[Bound]) -> _Rule:
    """`inner` checked, then held to its bounds; a refusal says what the first bound
    says, for data of the wrong kind as for a value out of bounds."""
    if not bounds:
        return inner
    expected = bounds[0].what

    def check(data: object, where: str) -> object:
        if _kind(data) not in inner.kinds:
            _refuse(where, expected, data)
        value = inner.decode(data, where)  # its own refusal: a list's item, a NUL in a path
        for bound in bounds:
            if not bound.holds(value):
                _refuse(where, bound.what, data, _why(bound, value))
        return value

    return _Rule(check, inner.kinds, expected)


def _why(bound: Bound, value: object) -> str:
    """What a text within its length is refused for: the characters."""
    within = isinstance(value, str | Path) and len(str(value)) <= getattr(bound, "longest", -1)
    return ", some of them not allowed here" if isinstance(bound, Text) and within else ""


def _union(members: tuple[_Rule, ...]) -> _Rule:
    """The first member that takes data of its shape builds it (`X | None`: X, or
    nothing); an int goes to an `int` member before a `float` one, whatever the order
    written, so that `float | int` gives back the int that was sent."""
    by_kind: dict[str, _Rule] = {}
    for member in members:
        for kind in member.kinds:
            by_kind.setdefault(kind, member)
    integer = next((m for m in members if m.kinds == frozenset({"int"})), None)
    if integer is not None:
        by_kind["int"] = integer
    expected = " or ".join(member.expected for member in members)

    def check(data: object, where: str) -> object:
        member = by_kind.get(_kind(data))
        if member is None:
            _refuse(where, expected, data)
        return member.decode(data, where)

    return _Rule(check, frozenset(by_kind), expected)


def _each(item: _Rule, data: list[object], where: str) -> list[object]:
    """The items built by `item`; a refusal names the first bad one's place."""
    try:
        return [item.decode(value, where) for value in data]
    except WireError:
        for index, value in enumerate(data):
            item.decode(value, f"{where}[{index}]")
        raise


def _sequence(item: _Rule, container: type) -> _Rule:
    noun = "a tuple" if container is tuple else "a list"
    expected = noun if item.kinds is _ANY else f"{noun} of {_plural(item.expected)}"

    def check(data: object, where: str) -> object:
        if type(data) is not list:
            _refuse(where, expected, data)
        return container(_each(item, data, where))

    return _Rule(check, frozenset({"list"}), expected)


def _fixed_tuple(items: tuple[_Rule, ...]) -> _Rule:
    expected = f"a list of {len(items)}: " + ", ".join(item.expected for item in items)

    def check(data: object, where: str) -> object:
        if type(data) is not list or len(data) != len(items):
            _refuse(where, expected, data)
        try:
            return tuple(item.decode(value, where) for item, value in zip(items, data, strict=True))
        except WireError:
            for index, (item, value) in enumerate(zip(items, data, strict=True)):
                item.decode(value, f"{where}[{index}]")
            raise

    return _Rule(check, frozenset({"list"}), expected)


def _mapping(value_rule: _Rule) -> _Rule:
    def check(data: object, where: str) -> object:
        if type(data) is not dict or _kind(data) != "dict":
            _refuse(where, "a dict", data)
        items = _unwrapped(data, where)
        return {key: value_rule.decode(value, f"{where}[{_name_shown(key)}]")
                for key, value in items.items()}  # fmt: skip

    return _Rule(check, frozenset({"dict"}), "a dict")


def _enum_rule(cls: type[enum.Enum]) -> _Rule:
    names = list(cls.__members__)
    expected = f"{_a(cls.__name__)} ({', '.join(names)})"
    return _Rule(functools.partial(_decode_enum, cls=cls, expected=expected),
                 frozenset({"enum"}), expected)  # fmt: skip


def _dataclass_rule(cls: type) -> _Rule:
    expected = _a(cls.__name__)

    def check(data: object, where: str) -> object:
        if type(data) is not dict or "type" not in data:
            _refuse(where, expected, data)
        found = registered(data["type"])
        if not (isinstance(found, type) and issubclass(found, cls)):
            _refuse(where, expected, data)
        return _build(found, data)

    return _Rule(check, frozenset({"type"}), expected)


def _decode_enum(data: object, where: str, cls: type[enum.Enum] = enum.Enum,
                 expected: str = "an enum member") -> enum.Enum:  # fmt: skip
    if type(data) is not dict or data.keys() != {"enum", "value"}:
        _refuse(where, expected, data)
    found, member = registered(data["enum"]), data["value"]
    if not (issubclass(found, enum.Enum) and issubclass(found, cls)):
        _refuse(where, expected, data)
    if not isinstance(member, str) or member not in found.__members__:
        raise WireError(f"{where}: {found.__name__} has no member {_name_shown(member)}")
    return found[member]


def _decode_error(data: object, where: str,
                  base: type[BaseException] = BaseException) -> BaseException:  # fmt: skip
    expected = "an error the robot reports"  # its class's name would read as Python's
    if type(data) is not dict or "error" not in data:
        _refuse(where, expected, data)
    cls = registered(data["error"])
    if not issubclass(cls, base):
        _refuse(where, expected, data)
    message, attrs = data.get("message"), decode(data.get("attrs", {}))
    if not isinstance(message, str) or not isinstance(attrs, dict):
        raise WireError(f"{cls.__name__}: an error needs a text message and a dict of attrs")
    # Built without calling __init__, whose arguments differ from class to class
    # (BoardError(line) prefixes its message): the message and attributes are restored.
    error = cls.__new__(cls)
    error.args = (message,)
    vars(error).update(attrs)
    return error


def _decode_path(data: object, where: str) -> Path:
    if type(data) is not dict or data.keys() != {"path"} or type(data["path"]) is not str:
        _refuse(where, "a path", data)
    if "\0" in data["path"]:  # no file is named so, and os calls refuse it with a ValueError
        _refuse(where, "a path without NUL characters", data, " with one")
    return Path(data["path"])


def _decode_bytes(data: object, where: str) -> bytes:
    if type(data) is not dict or data.keys() != {"bytes"} or type(data["bytes"]) is not str:
        _refuse(where, "bytes in base64", data)
    try:
        return base64.b64decode(data["bytes"], validate=True)
    except (binascii.Error, ValueError):  # ValueError: a non-ASCII character
        raise WireError(f"{where}: expected bytes in base64, got other text") from None


def _got(data: object) -> str:
    """What came, in words, without quoting it: a refusal goes back to the client."""
    if data is None:
        return "null"
    if isinstance(data, bool):
        return "true" if data else "false"
    if isinstance(data, int):
        return str(data) if abs(data) < 10**15 else "an integer of that length"
    if isinstance(data, float):
        return "NaN" if math.isnan(data) else f"{data:g}".replace("inf", "infinity")
    if isinstance(data, str | list):
        noun = ("character", "text") if isinstance(data, str) else ("item", "list")
        return f"a {noun[1]} of {len(data)} {noun[0]}{'' if len(data) == 1 else 's'}"
    kind = _kind(data)
    if kind == "type":
        name = typing.cast(dict[str, object], data)["type"]
        shown = isinstance(name, str) and _CLASS_NAME.match(name)
        return _a(typing.cast(str, name)) if shown else "an object of an unknown type"
    return {"dict": "a dict", "enum": "an enum member", "error": "an error",
            "path": "a path", "bytes": "bytes"}[kind]  # fmt: skip


def _name_shown(name: object) -> str:
    """A name a client sent, as a refusal may echo it: only when it looks like one."""
    if isinstance(name, str) and _CLASS_NAME.match(name):
        return repr(name)
    return "(a name of other characters)" if isinstance(name, str) else "(not a name)"


def _a(noun: str) -> str:
    """ "an Intent", "a Go"."""
    return f"{'an' if noun[:1] in 'AEIOUaeiou' else 'a'} {noun}"


def _plural(expected: str) -> str:
    """ "a text" -> "texts", for "a tuple of texts"."""
    for article in ("a ", "an "):
        if expected.startswith(article):
            word, _, rest = expected.removeprefix(article).partition(" ")
            return f"{word}s{' ' + rest if rest else ''}"
    return expected
