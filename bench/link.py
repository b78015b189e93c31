"""Benchmark: bulk_data round trips over a real pty to `giraff-console sim --pty`.

With pacing off the figure is the software overhead of both ends (the link in this
process, the simulator in another). With pacing on, each exchange cannot be faster
than its bytes take at 115200 baud; the ratio to that limit shows how close to the
line rate the link gets.

Usage: python bench/link.py [--seconds S]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import time

import giraff_console
from giraff_console.link import BoardLink
from giraff_console.protocol.framing import BYTE_TIME_S


def start_simulator(*args: str) -> tuple[subprocess.Popen, str]:
    process = subprocess.Popen(
        [sys.executable, "-m", "giraff_console", "sim", "--pty", *args],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    return process, process.stdout.readline().strip()


def measure(paced: bool, seconds: float) -> dict[str, float]:
    process, path = start_simulator(*(["--pace"] if paced else []))
    try:
        link = BoardLink.open(path)
        sizes = []
        link.add_observer(lambda e: sizes.append(len("get bulk_data\r") + len(e.lines[0]) + 8))
        for _ in range(50):  # warm up
            link.bulk()
        sizes.clear()
        durations = []
        end = time.perf_counter() + seconds
        while time.perf_counter() < end:
            start = time.perf_counter()
            link.bulk()
            durations.append(time.perf_counter() - start)
        link.close()
    finally:
        process.terminate()
        process.wait()
    line_limit = statistics.mean(sizes) * BYTE_TIME_S
    mean = statistics.mean(durations)
    return {
        "exchanges": len(durations),
        "per_second": len(durations) / sum(durations),
        "mean_ms": mean * 1e3,
        "p50_ms": statistics.median(durations) * 1e3,
        "p95_ms": statistics.quantiles(durations, n=20)[18] * 1e3,
        "bytes": statistics.mean(sizes),
        "line_limit_ms": line_limit * 1e3,
        "of_line_rate": line_limit / mean,
    }


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="per measurement")
    args = parser.parse_args()
    print(f"giraff-console {giraff_console.__version__}, Python {platform.python_version()}, "
          f"{platform.machine()}, {cpu_model()}, {os.cpu_count()} cores")  # fmt: skip
    print(f"{'pacing':<8}{'exchanges':>10}{'per s':>9}{'mean ms':>9}{'p50 ms':>8}"
          f"{'p95 ms':>8}{'bytes':>7}{'line ms':>9}{'of line':>9}")  # fmt: skip
    for paced in (False, True):
        r = measure(paced, args.seconds)
        print(f"{'on' if paced else 'off':<8}{r['exchanges']:>10}{r['per_second']:>9.0f}"
              f"{r['mean_ms']:>9.3f}{r['p50_ms']:>8.3f}{r['p95_ms']:>8.3f}{r['bytes']:>7.0f}"
              f"{r['line_limit_ms']:>9.2f}"
              f"{format(r['of_line_rate'], '>9.1%') if paced else '        -'}")  # fmt: skip
    print("off: software overhead per exchange; on: share of the 115200-baud limit achieved")


if __name__ == "__main__":
    main()
