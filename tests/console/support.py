"""Running the real console against `giraff-console sim --pty` and its pose log."""

from __future__ import annotations

import contextlib
import fcntl
import os
import pty
import select
import signal
import struct
import subprocess
import sys
import termios
import time
from dataclasses import dataclass
from pathlib import Path

from tests.conftest import CHILD_TIMEOUT, start_sim_process, stop_sim_process


@dataclass(frozen=True)
class Sample:
    time: float
    x: float
    y: float
    heading: float
    moving: bool


def read_pose_log(path: Path) -> list[Sample]:
    samples = []
    for line in path.read_text().splitlines():
        fields = line.split()
        if len(fields) == 5:
            t, x, y, h, moving = fields
            samples.append(Sample(float(t), float(x), float(y), float(h), moving == "1"))
    return samples


def pose_at(samples: list[Sample], t: float) -> Sample:
    """The last sample at or before `t`."""
    return [s for s in samples if s.time <= t][-1]


def settled(samples: list[Sample], after: float) -> Sample:
    """The first sample after `after` from which the robot no longer moves."""
    later = [s for s in samples if s.time > after]
    for i, sample in enumerate(later):
        if not any(s.moving for s in later[i:]):
            return sample
    raise AssertionError("the robot never stopped")


class SimulatedRobot:
    """`giraff-console sim --pty --pose-log` in another process."""

    def __init__(self, tmp_path: Path, *options: str) -> None:
        self.log = tmp_path / "pose.log"
        self.process, self.path = start_sim_process("--pose-log", str(self.log), *options)

    def samples(self) -> list[Sample]:
        return read_pose_log(self.log)

    def wait_until_still(self, timeout: float = 5.0) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            samples = self.samples()
            if samples and not samples[-1].moving and time.monotonic() - samples[-1].time < 0.2:
                return
            time.sleep(0.05)
        raise AssertionError("the robot never stopped")

    def close(self) -> None:
        assert stop_sim_process(self.process) == 0


# Where the simulator starts the robot: the origin, facing +x.
OPEN_FLOOR = Path(__file__).with_name("open-floor.yaml")


def console_command(port: str, *options: str) -> list[str]:
    return [sys.executable, "-m", "giraff_console", "--port", port,
            "--floorplan", str(OPEN_FLOOR), *options]  # fmt: skip


def run(args: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run(args, capture_output=True, text=True, timeout=CHILD_TIMEOUT)


UP = b"\x1b[A"


def spawn_console(port: str, *options: str) -> tuple[int, int]:
    """The real console in a new pseudo-terminal, 80x24; returns its pid and master fd."""
    pid, master = pty.fork()
    if pid == 0:  # the child: the pty is its controlling terminal
        os.environ["TERM"] = "xterm-256color"
        args = console_command(port, *options)
        os.execv(args[0], args)
    fcntl.ioctl(master, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 80, 0, 0))
    return pid, master


def drain(master: int, seconds: float) -> None:
    """Read the console's output for a while, so that it never blocks on writing."""
    end = time.monotonic() + seconds
    while (remaining := end - time.monotonic()) > 0:
        # A console that prints nothing must not hold the test in `read`.
        if not select.select([master], [], [], remaining)[0]:
            return
        try:
            os.read(master, 65536)
        except OSError:
            return
        time.sleep(0.01)


def wait_for_exit(pid: int, timeout: float, master: int | None = None) -> int | None:
    """The child's wait status, or None if it is still running after `timeout` seconds.

    Reads the terminal meanwhile (if `master` is given), so that a console busy drawing
    its last screen is not held up by the test.
    """
    end = time.monotonic() + timeout
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            return status
        if time.monotonic() >= end:
            return None
        if master is not None:
            drain(master, 0.01)  # at once if the terminal is closed
        time.sleep(0.01)


def end_console(pid: int, master: int | None) -> None:
    """Kill and reap the console if it still runs, and close its terminal: on every
    path out of a test, so that no console is left holding the board's pty."""
    try:
        running = wait_for_exit(pid, 0) is None
    except ChildProcessError:  # reaped already, by the test
        running = False
    if running:
        os.kill(pid, signal.SIGKILL)
        assert wait_for_exit(pid, CHILD_TIMEOUT) is not None, f"{pid} outlived SIGKILL"
    if master is not None:
        with contextlib.suppress(OSError):  # already closed: the test hung up
            os.close(master)


def hold_up(master: int, seconds: float) -> None:
    """Hold Up as a terminal repeats it: a press, then every 33 ms after 0.5 s."""
    os.write(master, UP)
    drain(master, 0.5)
    end = time.monotonic() + seconds - 0.5
    while time.monotonic() < end:
        os.write(master, UP)
        drain(master, 0.033)


class Tmux:
    def __init__(self, command: list[str]) -> None:
        self.socket = f"giraff-test-{os.getpid()}"
        self.tmux(
            "-f", "/dev/null", "new-session", "-d", "-x", "120", "-y", "40", " ".join(command)
        )
        self.tmux("set", "-sg", "escape-time", "10")
        self.pid = int(self.tmux("display-message", "-p", "#{pane_pid}"))

    def tmux(self, *args: str) -> str:
        result = subprocess.run(["tmux", "-L", self.socket, *args], capture_output=True,
                                text=True, timeout=CHILD_TIMEOUT)  # fmt: skip
        return result.stdout

    def keys(self, *keys: str) -> None:
        self.tmux("send-keys", *keys)

    def screen(self) -> str:
        return self.tmux("capture-pane", "-p")

    def wait_for(self, text: str, timeout: float = 15.0) -> str:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            screen = self.screen()
            if text in screen:
                return screen
            time.sleep(0.1)
        raise AssertionError(f"{text!r} never appeared:\n{self.screen()}")

    def hold(self, key: str, seconds: float) -> float:
        """Press, then repeat every 33 ms after 0.5 s; returns the time of the last repeat."""
        start = time.monotonic()
        self.keys(key)
        next_press = start + 0.5
        last = start
        while next_press < start + seconds:
            time.sleep(max(0.0, next_press - time.monotonic()))
            self.keys(key)
            last = time.monotonic()
            next_press += 0.033
        return last

    def kill(self) -> None:
        """Kill tmux, as a dropped SSH connection does; the console gets SIGHUP. One that
        outlives it for long is killed, so that it does not keep the board's pty."""
        self.tmux("kill-server")
        end = time.monotonic() + CHILD_TIMEOUT
        while time.monotonic() < end:
            try:
                os.kill(self.pid, 0)
            except ProcessLookupError:
                return
            time.sleep(0.05)
        with contextlib.suppress(ProcessLookupError):
            os.kill(self.pid, signal.SIGKILL)
