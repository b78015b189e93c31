"""Benchmark: decoding what crosses the daemon's socket (issue 30, item 4: every field
checked against its annotation, and no slower for it).

Every attached console decodes a Telemetry 20 times a second, and the daemon every
request. Timed here: `wire.decode` of a Telemetry with every field filled (the
test_wire fixture's, about 1.8 kB of JSON) and of a request (`Asked(7, Go("kitchen"))`),
against the peer, `json.loads` of the same line, which every message pays before it is
decoded. Best of 5 runs of N each, in microseconds a message.

Run it against an older tree to compare (the figures are the machine's of the moment,
so both in one sitting): `PYTHONPATH=OLD_TREE python bench/wire_decode.py`, where
OLD_TREE holds that commit's `giraff_console` and `tests` (`git archive COMMIT
giraff_console tests | tar -x -C OLD_TREE`).

Usage: python bench/wire_decode.py [--number N]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import timeit
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.append(str(ROOT))  # after PYTHONPATH: an older tree given there comes first

from giraff_console.service import commands as c  # noqa: E402
from giraff_console.service import daemon, wire  # noqa: E402
from tests.service.test_wire import full_telemetry  # noqa: E402


def best_us(call: object, number: int) -> float:
    return min(timeit.repeat(call, number=number, repeat=5)) / number * 1e6  # type: ignore[arg-type]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--number", type=int, default=5000, metavar="N")
    args = parser.parse_args()
    print(f"giraff_console from {Path(wire.__file__).resolve().parents[2]}")
    messages = {"Telemetry": full_telemetry(), "Asked(Go)": daemon.Asked(7, c.Go("kitchen"))}
    for name, message in messages.items():
        line = json.dumps(wire.encode(message))
        data = json.loads(line)
        assert wire.decode(data) == message
        decode = best_us(lambda data=data: wire.decode(data), args.number)
        parse = best_us(lambda line=line: json.loads(line), args.number)
        print(f"{name:>10} ({len(line)} bytes): wire.decode {decode:7.1f} us; "
              f"peer json.loads {parse:6.1f} us")  # fmt: skip
    print(f"load average {os.getloadavg()[0]:.2f}, {os.cpu_count()} cores")
    return 0


if __name__ == "__main__":
    sys.exit(main())
