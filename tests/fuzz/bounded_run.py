"""A command run as an operator runs it, to its end or a deadline, with its own CPU time
and peak memory: the bounds issue 30 puts on refusing any file made to hurt."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

# Issue 30's bound on the time a refusal of any file may take.
DEADLINE_S = 5.0
_POLL_S = 0.01


@dataclass(frozen=True)
class Finished:
    """How a command ended: its exit status (None: killed at the deadline), what it said
    (standard output, where `floorplan check` lists problems, then standard error), its
    wall time, its own CPU time and its own peak resident memory (KiB)."""

    status: int | None
    said: str
    seconds: float
    cpu_seconds: float
    peak_kib: int


# Linux carries a process's peak memory over exec, so a command started straight from the
# test would report the test's own (a hundred MB or more) as its peak: it is started
# from this small launcher, which reports the command's own rusage from wait4 to a file.
_LAUNCHER = """
import os, sys
report, command = sys.argv[1], sys.argv[2:]
pid = os.posix_spawn(command[0], command, os.environ)
_, status, usage = os.wait4(pid, 0)
with open(report, "w") as out:
    out.write(f"{usage.ru_maxrss} {usage.ru_utime + usage.ru_stime}")
sys.exit(os.waitstatus_to_exitcode(status) % 256)
"""


def run_bounded(folder: Path, *args: str, deadline: float = DEADLINE_S) -> Finished:
    """`giraff-console ARGS` in `folder`, with no settings file and no daemon to attach
    to, polled with wait4 until it ends or `deadline` passes (then killed, with its
    launcher). Its peak memory and CPU time are its own, as its launcher saw them."""
    env = os.environ | {"XDG_CONFIG_HOME": str(folder / "config"),
                        "XDG_DATA_HOME": str(folder / "data")}  # fmt: skip
    report = folder / f"rusage-{time.monotonic_ns()}"
    command = [sys.executable, "-c", _LAUNCHER, str(report), sys.executable, "-m", "giraff_console"]
    # Files, not pipes: a command that says much must not block on a full pipe.
    with tempfile.TemporaryFile(dir=folder) as stdout, tempfile.TemporaryFile(dir=folder) as stderr:
        started = time.monotonic()
        process = subprocess.Popen(
            [*command, *args], cwd=folder, env=env, stdin=subprocess.DEVNULL, stdout=stdout,
            stderr=stderr, start_new_session=True,
        )  # fmt: skip
        killed = False
        while True:
            pid, wait_status, _ = os.wait4(process.pid, os.WNOHANG)
            if pid:
                break
            if time.monotonic() - started > deadline:
                os.killpg(process.pid, signal.SIGKILL)  # the command and its launcher
                _, wait_status, _ = os.wait4(process.pid, 0)
                killed = True
                break
            time.sleep(_POLL_S)
        seconds = time.monotonic() - started
        # Reaped here: Popen must not wait for it again.
        process.returncode = os.waitstatus_to_exitcode(wait_status)
        said = b""
        for output in (stdout, stderr):
            output.seek(0)
            said += output.read()
    peak, cpu = (0, 0.0) if killed else report.read_text().split()
    return Finished(None if killed else process.returncode, said.decode("utf-8", "replace"),
                    seconds, float(cpu), int(peak))  # fmt: skip
