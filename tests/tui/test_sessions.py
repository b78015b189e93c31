"""Recording a session with R and playing it back with P, as an operator would."""

from __future__ import annotations

import asyncio
import json
import math
from pathlib import Path

import pytest
from textual.widgets import Label

from giraff_console.missions.route import load_route
from giraff_console.recording.control_log import read_log
from giraff_console.robot.telemetry import Telemetry
from tests.listening import only
from tests.tui.conftest import Rig

SIZE = (120, 36)


def collect_poses(rig: Rig, into: list, playback: bool = False):
    """Each new odometry sample and the pose it gave, as published live or played back."""

    def seen(telemetry) -> None:
        if playback != (telemetry.playback is not None):
            return
        state = telemetry.state
        if state is not None and (not into or into[-1][0] != state.received_at):
            into.append((state.received_at, telemetry.pose))

    listener = only(Telemetry, seen)
    rig.control.subscribe(listener)
    return listener


async def record_a_drive(rig: Rig, pilot) -> tuple[list, list[str]]:
    """A drive, then R, a drive with a curve and a turn, R; the live poses and transcript
    while recording. Recording starts away from where the odometry started, moving."""
    await rig.run(pilot, 0.2)
    await rig.hold(pilot, "right", 1.0)
    await rig.hold(pilot, "up", 1.0)
    assert rig.link.bulk().moving  # recording starts mid-drive
    await pilot.press("r")
    await rig.run(pilot, 0.1)
    poses: list = []
    collecting = collect_poses(rig, poses)
    first_line = len(rig.app.transcript.texts)
    await rig.hold(pilot, "up", 1.5)
    await rig.hold(pilot, "pageup", 1.5)
    await rig.run(pilot, 1.2)
    await rig.hold(pilot, "left", 1.0)
    await rig.run(pilot, 1.0)
    await pilot.press("enter", *"get v", "enter")  # a typed command is in the transcript too
    await rig.run(pilot, 0.2)
    rig.control.unsubscribe(collecting)
    await pilot.press("r")
    return poses, rig.app.transcript.texts[first_line:]


@pytest.mark.parametrize("firmware", ["thesis", "later", "giraff-x"])
async def test_a_session_plays_back_with_the_pose_and_transcript_it_was_recorded_with(
    tmp_path, firmware
):
    rig = Rig(recordings=tmp_path, firmware=firmware)
    async with rig.app.run_test(size=SIZE) as pilot:
        live_poses, live_lines = await record_a_drive(rig, pilot)
        session = rig.sessions.latest()
        assert session is not None and (session / "control.log").is_file()
        assert "recording stopped" in " ".join(rig.app.status_log.texts)
        assert rig.board.true_pose.x > 0.5  # it really drove

    replay = Rig(recordings=tmp_path, firmware=firmware)
    async with replay.app.run_test(size=SIZE) as pilot:
        await replay.run(pilot, 0.2)
        played_poses: list = []
        collect_poses(replay, played_poses, playback=True)
        first_line = len(replay.app.transcript.texts)
        await pilot.press("p")
        await replay.run(pilot, 0.05)
        assert "PLAYBACK" in str(replay.app.top_bar.render())
        start = replay.board.true_pose
        # Nothing typed reaches the robot either, nor do the driving keys.
        await type_command(pilot, "set p 0.2")
        await pilot.press("up", "u")
        assert "not sent: playing back" in " ".join(replay.app.status_log.texts)
        await replay.run(pilot, read_log(session / "control.log").duration + 0.5)
        assert replay.control.playback is None  # back to live at the end
        assert replay.board.true_pose == start  # nothing reached the robot

    # Every automatic poll recorded gives the pose the live console computed from it.
    origin = json.loads((session / "meta.json").read_text())["clock_origin"]
    played = dict(played_poses)
    misses, worst = 0, 0.0
    for t, pose in live_poses:
        match = played.get(float(f"{t - origin:.3f}"))
        if match is None:
            misses += 1
            continue
        worst = max(worst, math.hypot(match.x - pose.x, match.y - pose.y))
    print(f"\nreplayed pose: {len(live_poses)} samples, worst {worst * 1e6:.1f} um")
    assert misses == 0 and len(live_poses) > 100
    assert worst < 1e-3
    # Line for line, the transcript of the playback is the live one.
    played_lines = replay.app.transcript.texts[first_line:]
    assert played_lines[0] == "── playback ──"
    # Before the playback, the console stopped the live robot: that poll comes first.
    assert played_lines[1] == "> get bulk_data"
    # Recording began mid-drive, inside a run of identical lines that the transcript
    # folds: from the first command after that, the two agree.
    live_lines = live_lines[next(i for i, line in enumerate(live_lines) if line[0] == ">") :]
    start = played_lines.index(live_lines[0])
    assert start <= 16
    assert played_lines[start : start + len(live_lines)] == live_lines
    assert "> get v" in live_lines


async def type_command(pilot, text: str) -> None:
    await pilot.press("enter", *text, "enter")


async def teach(rig: Rig, pilot, name: str, drive) -> None:
    await type_command(pilot, f"teach {name}")
    await rig.run(pilot, 0.1)
    await drive()
    await type_command(pilot, "done")
    await rig.run(pilot, 0.1)


async def test_a_taught_route_replays_open_loop_to_where_teaching_ended(tmp_path):
    recordings = tmp_path / "recordings"
    rig = Rig(recordings=recordings)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.2)

        async def drive() -> None:
            await rig.hold(pilot, "up", 2.0)
            await rig.run(pilot, 1.0)
            await type_command(pilot, "mark hall")
            await rig.hold(pilot, "right", 1.5)
            await rig.run(pilot, 1.0)
            await rig.hold(pilot, "pageup", 2.0)
            await rig.run(pilot, 1.5)
            await type_command(pilot, "mark kitchen")

        await teach(rig, pilot, "hall-to-kitchen", drive)
        taught_end = rig.board.true_pose
        notes = " ".join(rig.app.status_log.texts)
        assert "route hall-to-kitchen saved" in notes and "marks: hall, kitchen" in notes

    route = load_route(tmp_path / "routes" / "hall-to-kitchen.yaml")
    assert [mark.name for mark in route.marks] == ["hall", "kitchen"]
    assert route.session is not None and (Path(route.session) / "control.log").is_file()

    # A fresh board, where teaching began: the route is read from its file again.
    replay = Rig(recordings=recordings)
    async with replay.app.run_test(size=SIZE) as pilot:
        await replay.run(pilot, 0.2)
        await type_command(pilot, "replay-route hall-to-kitchen")
        await replay.run(pilot, route.duration + 2.0)
        assert "hall-to-kitchen done" in " ".join(replay.app.status_log.texts)
        end = replay.board.true_pose
    assert math.hypot(end.x - taught_end.x, end.y - taught_end.y) < 0.05
    assert taught_end.x > 0.5 and abs(taught_end.y) > 0.1  # it went somewhere, and turned


async def test_a_two_round_patrol_of_two_routes_runs_to_the_end_with_progress(tmp_path):
    recordings = tmp_path / "recordings"
    rig = Rig(camera=True, recordings=recordings)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.2)

        async def out() -> None:
            await rig.hold(pilot, "up", 1.5)
            await rig.run(pilot, 1.0)

        async def back() -> None:
            await rig.hold(pilot, "down", 1.5)
            await rig.run(pilot, 1.0)

        await teach(rig, pilot, "out", out)
        await teach(rig, pilot, "back", back)
        # Teaching went out and back, but not quite to where it began; each round will too.
        residual = rig.board.true_pose.x
        (tmp_path / "routes" / "rounds.patrol.yaml").write_text(
            "rounds: 2\nsnapshots: true\nstops:\n"
            "  - {route: out, dwell: 2}\n  - {route: back, dwell: 1}\n"
        )
        await rig.show_camera(pilot)  # a frame for the snapshots
        await type_command(pilot, "patrol rounds")
        seen: set[str] = set()
        for _ in range(60):
            await rig.run(pilot, 0.5)
            shown = " ".join(str(label.content) for label in rig.app.main_view.query(Label))
            seen.update(part for part in ("round 1/2", "round 2/2", "stop 2/2") if part in shown)
            if rig.control.mission is None:
                break
        # The patrol's own recording ends with it, closed on a thread of its own.
        # Up to 10 s of real time: the closing thread may wait its turn on a busy machine.
        for _ in range(1000):
            if not rig.sessions.recording:
                break
            await asyncio.sleep(0.01)
        assert not rig.sessions.recording
        notes = " ".join(rig.app.status_log.texts)
    assert "rounds done" in notes
    assert seen == {"round 1/2", "round 2/2", "stop 2/2"}
    snapshots = sorted(p.name for p in recordings.glob("*/snapshots/*.jpg"))
    assert snapshots == [
        "round1-stop1-out.jpg", "round1-stop2-back.jpg",
        "round2-stop1-out.jpg", "round2-stop2-back.jpg",
    ]  # fmt: skip
    assert rig.board.true_pose.x == pytest.approx(3 * residual, abs=0.05)


async def test_a_patrol_started_again_keeps_its_recording_and_snapshots(tmp_path):
    recordings = tmp_path / "recordings"
    rig = Rig(camera=True, recordings=recordings)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.2)

        async def out() -> None:
            await rig.hold(pilot, "up", 0.6)
            await rig.run(pilot, 1.0)

        await teach(rig, pilot, "out", out)
        (tmp_path / "routes" / "once.patrol.yaml").write_text("rounds: 1\nstops: [{route: out}]\n")
        await rig.show_camera(pilot)
        await type_command(pilot, "patrol once")
        await rig.run(pilot, 0.3)
        await type_command(pilot, "patrol once")  # the operator starts it over
        for _ in range(20):
            await rig.run(pilot, 0.5)
            if rig.control.mission is None:
                break
        # Up to 10 s of real time: the closing thread may wait its turn on a busy machine.
        for _ in range(1000):
            if not rig.sessions.recording:
                break
            await asyncio.sleep(0.01)
        assert not rig.sessions.recording
    assert [p.name for p in recordings.glob("*/snapshots/*.jpg")] == ["round1-stop1-out.jpg"]
