"""What the odometry feed does when the board's readings go wrong: nothing agrees with
cdis, encoder counts that cannot be read, encoders set by hand; and which curves go out
as one twm (issue 13)."""

from __future__ import annotations

from dataclasses import replace

import pytest

from giraff_console.link import probe
from giraff_console.robot import control_loop
from giraff_console.robot.deadman import Intent
from giraff_console.robot.mission import MissionEnd, Outcome
from giraff_console.robot.odometry_feed import ENCODERS_PATIENCE_S
from giraff_console.robot.wheel_odometers import Reading
from tests.robot.test_odometry_firmware import TICK, Console, Straight

NOTHING_AGREES = "odometry: no wheel reading agrees with cdis"


def doubled_cdis(monkeypatch, console: Console) -> None:
    """From now on the board's cdis counts twice what the wheels do: no reading agrees
    with it (monkeypatch.undo puts it right)."""
    drive = console.board.drive
    reported = drive.reported_cdis
    monkeypatch.setattr(drive, "reported_cdis", lambda: 2 * reported())


def test_when_nothing_agrees_the_mission_stops_and_none_starts_until_a_check_passes(
    monkeypatch,
):
    console = Console("later")
    console.run(TICK)
    doubled_cdis(monkeypatch, console)
    ended: list[MissionEnd] = []
    console.loop.run_mission(Straight(), ended.append)
    console.run(3.0)
    assert ended == [
        MissionEnd(
            Outcome.LOST, "stopped: its pose cannot be trusted (no wheel reading agrees with cdis)"
        )
    ]
    console.run(1.0)
    at_rest = console.board.true_pose
    console.run(0.5)
    assert console.board.true_pose == at_rest  # stopped
    said = [r for r in console.reports if r.startswith(NOTHING_AGREES)]
    assert len(said) == 1
    assert said[0].endswith("missions are stopped and refused until a check passes: set "
                            "[board] odometers and wheel_base, or drive a metre by hand to "
                            "check again")  # fmt: skip
    # Driven by hand, the check runs again, and fails again: said once is enough.
    console.hold(Intent.FORWARD, 1.5)
    assert len([r for r in console.reports if r.startswith(NOTHING_AGREES)]) == 1
    refused: list[MissionEnd] = []
    console.loop.run_mission(Straight(), refused.append)
    console.run(TICK)
    assert [end.outcome for end in refused] == [Outcome.NOT_STARTED]
    assert console.reports[-1].startswith("straight not started: the odometry disagrees with "
                                          "cdis")  # fmt: skip
    assert "[board] odometers" in console.reports[-1]
    assert "drive a metre by hand" in console.reports[-1]
    # The board put right, a metre by hand: a check passes, and missions run again.
    monkeypatch.undo()
    console.hold(Intent.FORWARD, 2.5)
    assert console.reports[-1].startswith("odometry checked: imdl/imdr as increments agree")
    assert console.reports[-1].endswith("; missions may run again")
    started: list[str] = []
    console.loop.run_mission(Straight(), started.append)
    console.run(0.5)
    assert not started and console.loop.mission is not None


def unreadable_counts(monkeypatch, console: Console) -> dict[str, int]:
    """The board answers `get enc0` with garbage while `left` counts down (-1: forever)."""
    bad = {"left": 0}
    execute = console.board.execute

    def answer(line: str) -> bytes:
        if line.strip() == "get enc0" and bad["left"] != 0:
            bad["left"] -= 1
            return b"zz\r\nOK >\r\n"
        return execute(line)

    monkeypatch.setattr(console.board, "execute", answer)
    return bad


def test_a_few_unreadable_counts_skip_their_polls_and_end_nothing(monkeypatch):
    console = Console("later", odometers="encoders")
    console.run(TICK)
    bad = unreadable_counts(monkeypatch, console)
    ended: list[MissionEnd] = []
    console.loop.run_mission(Straight(), ended.append)
    console.run(1.0)
    bad["left"] = 5  # five polls in a row, a quarter of a second
    console.run(1.0)
    assert bad["left"] == 0  # they happened
    assert not ended
    assert console.reports[1:] == ["straight started"], console.reports
    assert console.loop.odometry.reading is Reading.ENCODERS
    console.loop.stop_mission()
    console.run(1.5)
    assert console.error()[0] <= 0.005  # the next counts covered the gap


def test_counts_unreadable_for_a_second_hand_over_to_imdl_imdr_with_one_line(monkeypatch):
    console = Console("later", odometers="encoders")
    console.run(TICK)
    bad = unreadable_counts(monkeypatch, console)
    asked: list[str] = []
    console.link.add_observer(lambda e: asked.append(e.command))
    ended: list[MissionEnd] = []
    console.loop.run_mission(Straight(), ended.append)
    console.run(1.0)
    bad["left"] = -1
    console.run(ENCODERS_PATIENCE_S + 1.0)
    assert not ended
    gave_up = [r for r in console.reports if r.startswith("odometry: the encoders")]
    assert gave_up == [
        "odometry: the encoders could not be read for 1 s (garbled value: 'zz'); reading "
        "imdl/imdr as increments instead; not read again until the board is reconnected"
    ]
    assert console.loop.odometry.reading is Reading.INCREMENTS
    asked.clear()
    console.run(1.0)
    assert "get enc0" not in asked
    console.loop.stop_mission()
    console.run(1.5)
    # The increments read while the counts were missing were integrated all along.
    assert console.error()[0] <= 0.01


def test_encoders_set_by_hand_are_not_taken_for_travel():
    console = Console("later", odometers="encoders")
    console.run(TICK)

    def set_by_hand(link) -> None:
        # Counts a few centimetres off, which the check on steps no wheel could make
        # would let through: 5 cm back on the left, 7.5 cm on ahead on the right.
        link.set("enc0", link.get("enc0") - 100)
        link.set("enc1", link.get("enc1") + 150)

    for tick in range(60):
        console.loop.press(Intent.FORWARD)
        if tick == 30:
            console.loop.submit(set_by_hand)
        console.loop.tick()
        console.clock.advance(TICK)
    console.run(1.5)
    assert console.board.true_pose.x > 0.8
    distance, heading = console.error()
    # The step from the last poll to the set is lost (a tick at 0.4 m/s), no more; and
    # no turn, where the counts taken for travel would make one of 14 degrees.
    assert distance <= 0.025 and heading <= 0.1


@pytest.mark.parametrize(("answers", "setting", "twm"), [
    (True, "auto", True),
    (False, "auto", False),
    (False, "on", True),  # a Giraff-X that does not answer `get twm`
    (True, "off", False),
])  # fmt: skip
def test_curves_go_out_as_one_twm_as_the_setting_says(monkeypatch, answers, setting, twm):
    monkeypatch.setattr(control_loop, "probe", lambda link: replace(probe(link), twm=answers))
    console = Console("giraff-x", twm=setting)
    sent: list[str] = []
    console.link.add_observer(lambda e: sent.append(e.command))
    console.run(TICK)
    console.hold(Intent.FORWARD_LEFT, 2.0)
    assert any(command.startswith("set twm ") for command in sent) == twm
    assert ("as the settings say" in console.reports[0]) == (setting != "auto")
    distance, heading = console.error()
    assert distance <= 0.01 and heading <= 0.5


def test_a_pose_jump_flagged_while_no_mission_ran_does_not_end_the_next_one():
    console = Console("thesis")
    console.run(TICK)
    # What a check decided by the stop's own read of bulk_data leaves behind.
    console.loop.feed.pose_jumped = "odometry: the board's imdl/imdr behave as totals"
    ended: list[MissionEnd] = []
    console.loop.run_mission(Straight(), ended.append)
    console.run(0.5)
    assert not ended and console.loop.mission is not None
