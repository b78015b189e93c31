"""Route files: whatever their bytes, load_route gives a Route or a RouteError that
names the file, never a traceback (issue 12)."""

from __future__ import annotations

import json

import yaml
from hypothesis import given

from giraff_console.missions.route import RouteError, load_route
from tests.fuzz.inputs import FUZZ, file_cases, replaced

# The example in routes/README.md.
SEED = b"""\
# A route taught to giraff-console; routes/README.md describes the format.
format: 1
taught: '2024-05-01T10:00:00+02:00'
session: recordings/20240501_100000
duration: 12.5
settings: {r: '1000', mode: '0', a: '0.5', v: '0.4', vg: '0', vgr: '1', cdp: '0'}
commands:
- [0.123, set v 0.3]
- [0.5, set p 0.288]
- [0.75, set p 0.288]
- [12.1, set p 0.04]
marks:
  kitchen: [12.4, 3.012, 0.105, 90.0]
path:
- [0.0, 0.0, 0.0, 0.0]
- [0.6, 0.1, 0.0, 0.0]
- [12.5, 3.012, 0.105, 90.0]
"""


def dump(document: object) -> bytes:
    """`document` as YAML: JSON is YAML, and json writes it ten times faster than
    yaml.dump; NaN and infinity are spelt the YAML way."""
    text = json.dumps(document).replace("-Infinity", "-.inf").replace("Infinity", ".inf")
    return text.replace("NaN", ".nan").encode()


def test_the_seed_is_a_good_route(folder):
    path = folder / "seed.yaml"
    path.write_bytes(SEED)
    assert load_route(path).marks[0].name == "kitchen"


def test_a_route_file_that_is_not_utf8_names_the_file_and_line(folder):
    path = folder / "bad.yaml"
    path.write_bytes(b"format: 1\n\xff\n")
    try:
        load_route(path)
    except RouteError as error:
        assert str(error) == f"{path}:2: not UTF-8 text (byte 0xff)"
    else:
        raise AssertionError("a file that is not UTF-8 loaded")


@FUZZ
@given(data=file_cases(SEED, replaced(yaml.safe_load(SEED), dump)))
def test_any_bytes_give_a_route_or_a_route_error(folder, data):
    path = folder / "fuzzed.yaml"
    path.write_bytes(data)
    try:
        load_route(path)
    except RouteError as error:
        assert str(error).startswith(f"{path}:")
