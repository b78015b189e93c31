"""`serve --fleet` refuses a broker it cannot use at once, with exit code 2 and why, and
leaves nothing behind (it once hung with its socket made)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.service.daemon_rig import run_cli

pytestmark = pytest.mark.timeout(60)


@pytest.mark.parametrize(
    ("option", "said"),
    [
        (["--fleet", "http://broker"], "mqtt://HOST[:PORT] or mqtts://HOST[:PORT]"),
        (["--fleet", "mqtt://ada:secret@broker"], "credentials go in a file"),
        (["--fleet", "mqtt://broker", "--serial-number", "giraff:7"], "cannot be a topic level"),
    ],
)
def test_serve_refuses_a_fleet_it_cannot_join(
    option, said, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
):
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    done = run_cli("serve", "--sim", "--no-landmarks", *option)
    assert done.returncode == 2
    assert said in done.stderr
    assert not list(tmp_path.rglob("*.sock"))
