"""A real MQTT broker on 127.0.0.1 for the fleet tests (issue 28, "Real parts"):
Mosquitto where it is installed, otherwise amqtt, which the test extra installs. Each
listens on a free port of its own and nothing else; it can be killed (as a broker that
dies) and started again on the same port. GIRAFF_TEST_BROKER=amqtt (or mosquitto) says
which."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

START_S = 15.0


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


class Broker:
    """A broker process on 127.0.0.1:`port`; `kind` is "mosquitto" or "amqtt"."""

    def __init__(self, folder: Path, port: int | None = None, kind: str | None = None) -> None:
        self.folder = folder
        self.port = port or free_port()
        # GIRAFF_TEST_BROKER=amqtt runs the tests as a machine without Mosquitto does.
        self.kind = (
            kind
            or os.environ.get("GIRAFF_TEST_BROKER")
            or ("mosquitto" if shutil.which("mosquitto") else "amqtt")
        )
        self.process: subprocess.Popen[bytes] | None = None

    @property
    def url(self) -> str:
        return f"mqtt://127.0.0.1:{self.port}"

    def start(self) -> Broker:
        log = (self.folder / f"{self.kind}.log").open("ab")
        self.process = subprocess.Popen(self._command(), stdout=log, stderr=log,
                                        stdin=subprocess.DEVNULL)  # fmt: skip
        log.close()
        deadline = time.monotonic() + START_S
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(f"{self.kind} ended at once: see {self.folder}")
            with socket.socket() as probe:
                probe.settimeout(0.2)
                if probe.connect_ex(("127.0.0.1", self.port)) == 0:
                    return self
            time.sleep(0.05)
        self.stop()
        raise RuntimeError(f"{self.kind} did not listen on {self.port} in {START_S} s")

    def kill(self) -> None:
        """As a broker that dies: SIGKILL, no goodbye to its clients."""
        if self.process is not None and self.process.poll() is None:
            self.process.send_signal(signal.SIGKILL)
            self.process.wait(5.0)

    def stop(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(5.0)
            except subprocess.TimeoutExpired:
                self.kill()

    def _command(self) -> list[str]:
        if self.kind == "mosquitto":
            config = self.folder / "mosquitto.conf"
            config.write_text(f"listener {self.port} 127.0.0.1\nallow_anonymous true\n"
                              "persistence false\n")  # fmt: skip
            return ["mosquitto", "-c", str(config)]
        config = self.folder / "amqtt.yaml"
        config.write_text(
            "listeners:\n  default:\n    type: tcp\n"
            f"    bind: 127.0.0.1:{self.port}\n"
            "    max_connections: 1000\n"
            "plugins:\n  amqtt.plugins.authentication.AnonymousAuthPlugin:\n"
            "    allow_anonymous: true\n"
        )
        return [str(Path(sys.executable).with_name("amqtt")), "-c", str(config)]
