"""Reading the YAML files people write and edit: routes and patrols.

Every complaint names the file, the line where one is known, and the key, so that a typo
in a hand-edited file is found at once (routes/README.md). Whatever the bytes, the only
exception that comes out is the caller's own error class (issue 12: no traceback for any
input).
"""

from __future__ import annotations

import math
import re
import reprlib
from pathlib import Path
from typing import Any, NoReturn

from giraff_console.file_limits import read_bounded, too_many
from giraff_console.planning.floorplan import Where, _node_lines, dotted
from giraff_console.yaml_source import YamlSourceError, parse_yaml

_NAME = re.compile(r"[A-Za-z0-9_-]{1,64}\Z")
# The last part of a dotted key (`.name` or `[3]`), dropped to find the nearest line.
_LAST_PART = re.compile(r"(\.[^.\[]*|\[\d+\])\Z")
# Values quoted in messages are cut short: a file may hold a megabyte on one key, or
# lists nested a thousand deep, which a plain repr would print whole or not at all.
_SHORT = reprlib.Repr()
_SHORT.maxlevel, _SHORT.maxstring, _SHORT.maxother, _SHORT.maxlong = 3, 60, 60, 40


def shown(value: object) -> str:
    """A value as a message quotes it: short, whatever its size or depth."""
    return _SHORT.repr(value)


def name_problem(name: object, what: str) -> str | None:
    """What is wrong with a route or place name, if anything: names become file names
    and words typed in commands."""
    if not isinstance(name, str) or not _NAME.match(name):
        return f"{what} name {shown(name)} may use only letters, digits, '-' and '_' (up to 64)"
    return None


class YamlFile:
    """A route or patrol file being read: every complaint names the file and the key."""

    def __init__(self, path: Path, error: type[Exception]) -> None:
        self.path, self.error = path, error
        self.lines: dict[str, int] = {}

    def fail(self, message: str, where: str = "", line: int | None = None) -> NoReturn:
        """Raise the caller's error as `file:line: message`, at the line of `where`."""
        line = line if line is not None else self._line(where)
        raise self.error(f"{self.path}:{line}: {message}" if line else f"{self.path}: {message}")

    def _line(self, where: str) -> int | None:
        key = where.split(" ")[0]
        while key:
            if key in self.lines:
                return self.lines[key]
            shorter = _LAST_PART.sub("", key)
            if shorter == key:
                break
            key = shorter
        return None

    def mapping(self, required: tuple[str, ...], optional: tuple[str, ...]) -> dict[str, Any]:
        """The whole file, which must be a mapping with these keys."""
        try:
            data = read_bounded(self.path)
        except OSError as error:
            self.fail(f"cannot read it: {error.strerror or error}")
        try:
            node, document = parse_yaml(data)
        except YamlSourceError as error:
            self.fail(error.message, line=error.line)
        lines: dict[Where, int] = {}
        duplicates: list[tuple[Where, str, int]] = []
        if node is not None:
            _node_lines(node, (), lines, duplicates)
        self.lines = {dotted(where): line for where, line in lines.items()}
        for where, key, line in duplicates:
            self.fail(f"duplicate key {dotted((*where, key))}", line=line)
        return self.table(document, "", (*required, *optional), required)

    def table(
        self,
        value: object,
        where: str,
        keys: tuple[str, ...] | None,
        required: tuple[str, ...] = (),
    ) -> dict[str, Any]:
        """A mapping with only `keys` (any, if None) and all of `required`."""
        if not isinstance(value, dict):
            self.fail(
                f"{where or 'the file'} should be a mapping of keys, not {shown(value)}", where
            )
        dotted = f"{where}." if where else ""
        for key in value:
            if keys is not None and key not in keys:
                name = f"{key if isinstance(key, str) else shown(key):.64}"
                self.fail(f"unknown key {dotted}{name} (expected {', '.join(keys)})", dotted + name)
        for key in required:
            if key not in value:
                self.fail(f"missing key {dotted}{key}", where)
        return value

    def number(self, value: object, where: str, minimum: float | None = None) -> float:
        """A finite number; an int too large for a float is out of range, not an error
        of Python's (`1e308` is a float, `10**400` an int, and both are written)."""
        if isinstance(value, bool) or not isinstance(value, int | float):
            self.fail(f"{where} should be a number, not {shown(value)}", where)
        try:
            number = float(value)
        except OverflowError:
            self.fail(f"{where} is {shown(value)}, out of range", where)
        if math.isnan(number):
            self.fail(f"{where} should be a number, not {shown(value)}", where)
        if math.isinf(number) or (minimum is not None and number < minimum):
            self.fail(f"{where} is {number}, out of range", where)
        return number

    def name(self, value: object, what: str, where: str = "") -> str:
        problem = name_problem(value, what)
        if problem:
            self.fail(problem, where)
        assert isinstance(value, str)
        return value

    def text(self, value: object, where: str) -> str:
        if not isinstance(value, str):
            self.fail(f"{where} should be text, not {shown(value)}", where)
        return value

    def within_limit(self, items: list[Any] | dict[Any, Any], where: str, what: str) -> None:
        """Refuse more `what` in `items` than the `waypoints` limit (file_limits.py), before
        any of them is read: a route of a million points is a mistake, not a route."""
        message = too_many(len(items), "waypoints", what)
        if message is not None:
            self.fail(f"{where}: {message}", where)

    def timed_rows(self, value: object, where: str, width: int) -> list[list[Any]]:
        """Rows `[offset, ...]` of `width` items, their offsets never going backwards."""
        if not isinstance(value, list):
            self.fail(f"{where} should be a list, not {shown(value)}", where)
        self.within_limit(value, where, "rows")
        previous = 0.0
        rows = []
        for i, row in enumerate(value):
            if not isinstance(row, list) or len(row) != width:
                self.fail(
                    f"{where}[{i}] should be a list of {width} items, not {shown(row)}",
                    f"{where}[{i}]",
                )
            offset = self.number(row[0], f"{where}[{i}] offset", minimum=0)
            if offset < previous:
                self.fail(
                    f"{where}[{i}]: time goes backwards, {offset} s after {previous} s",
                    f"{where}[{i}]",
                )
            previous = offset
            rows.append([offset, *row[1:]])
        return rows
