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
other. Decoding raises WireError, never a TypeError, on anything it cannot build.

Floats inf, -inf and nan pass through as they are: `json.dumps` (allow_nan, its
default) writes them as Infinity and NaN, which are not JSON but which `json.loads`
reads back. Both ends are this module, so that is enough; a gvr at vg = 1 is infinite
(link/motor_state.py).
"""

from __future__ import annotations

import base64
import binascii
import dataclasses
import enum
import functools
import types
import typing
from pathlib import Path
from typing import Any

_TAGS = frozenset({"type", "enum", "error", "path", "dict", "bytes"})

_registry: dict[str, type] = {}


class WireError(Exception):
    """A value that cannot be put on the wire, or wire data that cannot be built."""


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


def registered(name: str) -> type:
    """The class registered under this name; WireError if there is none."""
    try:
        return _registry[name]
    except KeyError:
        raise WireError(f"unknown type {name!r}") from None


def _check_registered(cls: type) -> str:
    if _registry.get(cls.__name__) is not cls:
        raise WireError(f"{cls.__module__}.{cls.__qualname__} is not registered to cross")
    return cls.__name__


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


def decode(data: object) -> object:
    """The value that `encode` turned into `data`; WireError if it cannot be built."""
    if isinstance(data, list):
        return [decode(item) for item in data]
    if not isinstance(data, dict):
        return data
    if "type" in data:
        return _decode_dataclass(data)
    if "enum" in data:
        return _decode_enum(data)
    if "error" in data:
        return _decode_error(data)
    if "path" in data:
        if not isinstance(data["path"], str):
            raise WireError(f"a path must be a str, not {data['path']!r:.40}")
        return Path(data["path"])
    if "bytes" in data:
        try:
            return base64.b64decode(str(data["bytes"]), validate=True)
        except (binascii.Error, ValueError):
            raise WireError(f"bytes that are not base64: {data['bytes']!r:.40}") from None
    if "dict" in data:
        inner = data["dict"]
        if not isinstance(inner, dict):
            raise WireError(f"a wrapped dict must hold a dict, not {inner!r:.40}")
        return {key: decode(item) for key, item in inner.items()}
    return {key: decode(item) for key, item in data.items()}


def _decode_dataclass(data: dict[str, object]) -> object:
    name = data["type"]
    cls = registered(str(name))
    if not dataclasses.is_dataclass(cls):
        raise WireError(f"{name!r} is not a dataclass")
    hints = _field_hints(cls)
    values = {key: item for key, item in data.items() if key != "type"}
    extra = sorted(set(values) - set(hints))
    if extra:
        raise WireError(f"{name}: unknown field {', '.join(map(repr, extra))}")
    missing = [
        field.name
        for field in dataclasses.fields(cls)
        if field.init
        and field.name not in values
        and field.default is dataclasses.MISSING
        and field.default_factory is dataclasses.MISSING
    ]
    if missing:
        raise WireError(f"{name}: missing field {', '.join(map(repr, missing))}")
    kwargs = {key: _fit(decode(item), hints[key]) for key, item in values.items()}
    try:
        return cls(**kwargs)
    except (TypeError, ValueError) as error:  # a __post_init__ that refuses the values
        raise WireError(f"{name}: {error}") from error


def _decode_enum(data: dict[str, object]) -> enum.Enum:
    cls = registered(str(data["enum"]))
    if not issubclass(cls, enum.Enum):
        raise WireError(f"{data['enum']!r} is not an enum")
    member = data.get("value")
    if not isinstance(member, str) or member not in cls.__members__:
        raise WireError(f"{cls.__name__} has no member {member!r:.40}")
    return cls[member]


def _decode_error(data: dict[str, object]) -> BaseException:
    cls = registered(str(data["error"]))
    if not issubclass(cls, BaseException):
        raise WireError(f"{data['error']!r} is not an exception")
    message, attrs = data.get("message"), decode(data.get("attrs", {}))
    if not isinstance(message, str) or not isinstance(attrs, dict):
        raise WireError(f"{cls.__name__}: an error needs a str message and a dict of attrs")
    # Built without calling __init__, whose arguments differ from class to class
    # (BoardError(line) prefixes its message): the message and attributes are restored.
    error = cls.__new__(cls)
    error.args = (message,)
    vars(error).update(attrs)
    return error


@functools.cache
def _field_hints(cls: type) -> dict[str, object]:
    """The `__init__` fields' resolved annotations. The project's dataclasses use
    `from __future__ import annotations`, so the annotations are strings, which
    get_type_hints resolves in the class's module."""
    try:
        hints = typing.get_type_hints(cls)
    except Exception as error:  # a name that only exists under TYPE_CHECKING
        raise WireError(f"cannot read {cls.__qualname__}'s field types: {error}") from error
    return {field.name: hints.get(field.name) for field in dataclasses.fields(cls) if field.init}


def _fit(value: object, hint: object) -> object:
    """A decoded value shaped as the annotation says: JSON lists back into tuples."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is typing.Annotated:
        return _fit(value, args[0])
    if origin is typing.Union or origin is types.UnionType:
        if value is None:
            return None
        # `X | None` and the like: the first member that can hold a list or a dict.
        wanted = (tuple, list) if isinstance(value, list) else (dict,)
        for member in args:
            if (typing.get_origin(member) or member) in wanted:
                return _fit(value, member)
        return value
    if isinstance(value, list):
        if hint is tuple:
            return tuple(value)
        if origin is tuple:
            if len(args) == 2 and args[1] is Ellipsis:
                return tuple(_fit(item, args[0]) for item in value)
            if args and len(args) == len(value):
                return tuple(_fit(item, arg) for item, arg in zip(value, args, strict=True))
            return tuple(value)
        if origin is list and args:
            return [_fit(item, args[0]) for item in value]
    if isinstance(value, dict) and origin is dict and len(args) == 2:
        return {key: _fit(item, args[1]) for key, item in value.items()}
    return value
