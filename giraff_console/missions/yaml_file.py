"""Reading the YAML files people write and edit: routes and patrols.

Every complaint names the file and the key, so that a typo in a hand-edited file is
found at once (routes/README.md).
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any, NoReturn

import yaml

_NAME = re.compile(r"[A-Za-z0-9_-]{1,64}\Z")


def name_problem(name: object, what: str) -> str | None:
    """What is wrong with a route or place name, if anything: names become file names
    and words typed in commands."""
    if not isinstance(name, str) or not _NAME.match(name):
        return f"{what} name {name!r} may use only letters, digits, '-' and '_' (up to 64)"
    return None


class YamlFile:
    """A route or patrol file being read: every complaint names the file and the key."""

    def __init__(self, path: Path, error: type[Exception]) -> None:
        self.path, self.error = path, error

    def fail(self, message: str) -> NoReturn:
        raise self.error(f"{self.path}: {message}")

    def mapping(self, required: tuple[str, ...], optional: tuple[str, ...]) -> dict[str, Any]:
        """The whole file, which must be a mapping with these keys."""
        try:
            document = yaml.safe_load(self.path.read_text(encoding="utf-8"))
        except OSError as error:
            self.fail(f"cannot read it: {error.strerror}")
        except yaml.YAMLError as error:
            self.fail(f"not YAML: {' '.join(str(error).split())}")
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
            self.fail(f"{where or 'the file'} should be a mapping of keys, not {value!r}")
        dotted = f"{where}." if where else ""
        for key in value:
            if keys is not None and key not in keys:
                self.fail(f"unknown key {dotted}{key} (expected {', '.join(keys)})")
        for key in required:
            if key not in value:
                self.fail(f"missing key {dotted}{key}")
        return value

    def number(self, value: object, where: str, minimum: float | None = None) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float) or math.isnan(value):
            self.fail(f"{where} should be a number, not {value!r}")
        if math.isinf(value) or (minimum is not None and value < minimum):
            self.fail(f"{where} is {value}, out of range")
        return float(value)

    def name(self, value: object, what: str) -> str:
        problem = name_problem(value, what)
        if problem:
            self.fail(problem)
        assert isinstance(value, str)
        return value

    def text(self, value: object, where: str) -> str:
        if not isinstance(value, str):
            self.fail(f"{where} should be text, not {value!r}")
        return value

    def timed_rows(self, value: object, where: str, width: int) -> list[list[Any]]:
        """Rows `[offset, ...]` of `width` items, their offsets never going backwards."""
        if not isinstance(value, list):
            self.fail(f"{where} should be a list, not {value!r}")
        previous = 0.0
        for i, row in enumerate(value):
            if not isinstance(row, list) or len(row) != width:
                self.fail(f"{where}[{i}] should be a list of {width} items, not {row!r}")
            offset = self.number(row[0], f"{where}[{i}] offset", minimum=0)
            if offset < previous:
                self.fail(f"{where}[{i}]: time goes backwards, {offset} s after {previous} s")
            previous = offset
        return [[float(row[0]), *row[1:]] for row in value]
