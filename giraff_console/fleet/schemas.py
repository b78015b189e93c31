"""VDA 5050's own JSON schemas, as the vda5050-sdk package ships them (copies of the
standard's published `json_schemas`, version 2.1; not retyped here), and the check of a
message against them.

Only the package's schema files are read: importing the package itself would load
pydantic and its models, which the robot does not need.
"""

from __future__ import annotations

import functools
import importlib.util
import json
from pathlib import Path
from typing import Any

from jsonschema import Draft202012Validator

from giraff_console.fleet.topics import Topic

PACKAGE = "vda5050"


class SchemasMissing(RuntimeError):
    """The package with the schemas is not installed."""


def schema_folder() -> Path:
    spec = importlib.util.find_spec(PACKAGE)
    if spec is None or not spec.submodule_search_locations:
        raise SchemasMissing("the VDA 5050 schemas are missing: pip install vda5050-sdk")
    return Path(next(iter(spec.submodule_search_locations))) / "validation" / "schemas"


@functools.cache
def _validator(kind: Topic) -> Draft202012Validator:
    path = schema_folder() / f"{kind.value}.json"
    try:
        schema = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        raise SchemasMissing(f"the VDA 5050 schema {path} cannot be read: {error}") from None
    return Draft202012Validator(schema)


def problem(kind: Topic, message: Any) -> str | None:
    """What is wrong with `message` as a `kind` message by the standard's schema (the
    first thing found, with where it is), or None if nothing."""
    error = next(iter(_validator(kind).iter_errors(message)), None)
    if error is None:
        return None
    where = "/".join(str(part) for part in error.absolute_path) or "the message"
    return f"{where}: {error.message[:200]}"
