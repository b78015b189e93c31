"""The fleet link's own files, the credentials and the certificate authorities, are read
within bounds as every file is (issue 30: file_limits.py): a FIFO, a device or a file
too large is refused at once with its path, never waited on or read for ever."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from giraff_console import file_limits
from giraff_console.fleet.broker_link import Broker, BrokerError, BrokerLink

pytestmark = pytest.mark.timeout(20)  # a FIFO read as it was waited for a writer for ever


def fifo(path: Path) -> Path:
    os.mkfifo(path, 0o600)
    return path


def test_credentials_that_are_a_fifo_are_refused_at_once(tmp_path: Path) -> None:
    broker = Broker.parse("mqtt://127.0.0.1:1883", credentials=fifo(tmp_path / "login"))
    with pytest.raises(BrokerError, match=r"login: .*FIFO"):
        broker.login()


def test_credentials_larger_than_the_limit_are_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    login = tmp_path / "login"
    login.write_text("robot:" + "x" * 2000)
    login.chmod(0o600)
    broker = Broker.parse("mqtt://127.0.0.1:1883", credentials=login)
    assert broker.login() == ("robot", "x" * 2000)
    # The settings' [limits] as `serve` puts them in place; put back after the test.
    monkeypatch.setattr(file_limits, "_current", file_limits.FileLimits(file_bytes=1024))
    with pytest.raises(BrokerError, match=r"login: it holds 2,006 bytes, more than the 1,024"):
        broker.login()


@pytest.mark.parametrize("kind", ["fifo", "device"])
def test_certificate_authorities_that_are_no_file_are_refused_at_once(
    kind: str, tmp_path: Path
) -> None:
    authorities = tmp_path / "ca.pem"
    if kind == "fifo":
        fifo(authorities)
    else:
        authorities.symlink_to("/dev/zero")
    broker = Broker.parse("mqtts://127.0.0.1:8883", ca_file=authorities)
    with pytest.raises(BrokerError, match=r"ca\.pem: .*(FIFO|device)"):
        BrokerLink(broker, "giraff-test")
