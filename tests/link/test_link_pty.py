"""The link against `giraff-console sim --pty` running in another process."""

from __future__ import annotations

import subprocess
import sys
import threading
import time

import pytest

from giraff_console.link import BoardLink, LinkDisconnected
from tests.conftest import start_sim_process, stop_sim_process


def test_handshake_over_a_real_pty(sim_pty):
    link = BoardLink.open(sim_pty)
    assert link.version == "1.1.112p-sim, 2013-06-01"
    link.close()
    time.sleep(0.1)  # as long as a board's power line would stay low
    again = BoardLink.open(sim_pty)  # every new connection is greeted
    assert again.version == link.version
    again.close()


def test_send_prints_the_eight_bulk_fields_decoded(sim_pty):
    result = subprocess.run(
        [sys.executable, "-m", "giraff_console", "send", "--port", sim_pty, "get bulk_data"],
        capture_output=True, text=True, timeout=10,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0] == "> get bulk_data"
    fields = [line.split()[0] for line in lines[1:]]
    assert fields == ["cang", "cdis", "gvr", "tilt_angle_from_home", "imdl", "imdr", "cvg", "mode"]
    assert lines[4].split()[1] == "0.08727"  # the home tilt, decoded from F*


def test_a_one_metre_move_stops_at_one_metre_after_3_3_seconds(sim_pty):
    link = BoardLink.open(sim_pty)
    for name, value in (("r", 1), ("a", 0.5), ("v", 0.4)):
        link.set(name, value)
    link.set("p", 1)
    started = time.monotonic()
    state = link.bulk()
    while state.moving:
        assert time.monotonic() - started < 6, "the move did not end"
        time.sleep(0.005)
        state = link.bulk()
    elapsed = state.received_at - started
    assert state.cdis == pytest.approx(1.000, abs=0.001)
    assert elapsed == pytest.approx(3.3, abs=0.1)
    link.close()


def test_concurrent_callers_each_get_their_own_answer(sim_pty):
    link = BoardLink.open(sim_pty)
    link.set("v", 0.3)
    link.set("a", 0.5)
    errors: list[str] = []

    def ask(name: str, expected: float) -> None:
        for _ in range(100):
            value = link.get(name)
            if value != pytest.approx(expected):
                errors.append(f"{name} gave {value}")

    threads = [threading.Thread(target=ask, args=args, daemon=True)
               for args in (("v", 0.3), ("a", 0.5))]  # fmt: skip
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=30)  # 200 exchanges, on a loaded machine
        assert not thread.is_alive(), "a caller is still waiting for its answer"
    assert errors == []
    link.close()


def test_a_simulator_that_dies_is_a_disconnection_not_a_hang():
    process, path = start_sim_process()
    link = BoardLink.open(path)
    stop_sim_process(process)
    start = time.monotonic()
    with pytest.raises(LinkDisconnected):
        link.get("v")
    assert time.monotonic() - start < 1.5


def test_paced_simulator_answers_at_line_rate():
    process, path = start_sim_process("--pace")
    try:
        link = BoardLink.open(path)
        exchanges = []
        for _ in range(20):
            start = time.monotonic()
            link.bulk()
            exchanges.append(time.monotonic() - start)
        # Every exchange takes the line's time; the fastest shows that pacing adds no more,
        # while on a loaded machine any one exchange may wait for the CPU.
        assert min(exchanges) >= 0.0139
        assert min(exchanges) < 0.03
    finally:
        stop_sim_process(process)


def test_sim_options_reach_the_board_over_the_pty():
    process, path = start_sim_process("--ca", "--hex-upper", "--set-reply", "none")
    try:
        link = BoardLink.open(path)
        lines: list[str] = []
        link.add_observer(lambda exchange: lines.extend(exchange.lines))
        assert link.set("v", 0.3) is None  # answered with the prompt alone
        assert link.get("v") == pytest.approx(0.3)
        assert lines == ["F*9A99993E"]
        link.close()
    finally:
        stop_sim_process(process)


def test_imperfect_sim_misses_its_targets_by_millimetres():
    process, path = start_sim_process("--imperfect", "--seed", "11")
    try:
        link = BoardLink.open(path)
        for name, value in (("r", 1), ("a", 1.0), ("v", 0.5), ("p", 0.2)):
            link.set(name, value)
        deadline = time.monotonic() + 5
        while link.bulk().moving and time.monotonic() < deadline:
            time.sleep(0.02)
        miss = abs(link.bulk().cdis - 0.2)
        assert 0.0 < miss <= 0.009
        link.close()
    finally:
        stop_sim_process(process)
