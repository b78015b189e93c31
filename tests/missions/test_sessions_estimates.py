"""A session recorded with the pose filter keeps its estimate beside the odometry, plays
it back as it was seen, and exports it with its covariance (issue 14): the control loop
on the simulator, real files written and read back."""

from __future__ import annotations

import bisect
import json
import math
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from giraff_console.cli.main import main
from giraff_console.link import BoardLink
from giraff_console.missions.sessions import Sessions
from giraff_console.recording.playback import open_estimates
from giraff_console.recording.session import RecordingSetup, read_meta
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman, Intent
from giraff_console.robot.ekf import Observation
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.odometry import Pose
from giraff_console.robot.telemetry import Telemetry
from giraff_console.robot.teleop import Teleop
from tests.listening import notes_into, only

TICK = 0.05
SAMPLE = Path(__file__).resolve().parents[2] / "recordings" / "sample"
# On the wall ahead and to the left of the robot's start, facing back at it.
MARKER = Pose(3.0, 0.5, math.pi)
SIGHTED_AT = (30, 50)  # ticks


class Console:
    """The control loop on a simulated board, with sessions recorded into `root`."""

    def __init__(self, root: Path) -> None:
        self.link = BoardLink.open("giraff-sim://?clock=virtual")
        self.clock = self.link.port.clock
        self.control = ControlLoop(lambda: self.link, teleop=Teleop(),
                                   deadman=Deadman(self.clock), clock=self.clock)  # fmt: skip
        self.notes: list[str] = []
        self.control.subscribe(notes_into(self.notes))
        setup = RecordingSetup(port="giraff-sim://?clock=virtual")
        self.sessions = Sessions(self.control, None, root, setup, self.notes.append)
        self.published: list[tuple[float, Telemetry]] = []
        self.control.subscribe(
            only(Telemetry, lambda telemetry: self.published.append((self.clock.now(), telemetry)))
        )

    def tick(self) -> None:
        self.control.tick()
        self.clock.advance(TICK)


@dataclass
class Recording:
    path: Path
    live: list[tuple[float, Estimate]]  # seconds into the session, the estimate published
    origin: float  # the loop's clock when the session began


def record_past_a_marker(root: Path) -> Recording:
    """Four seconds of driving a curve with a marker in the plan, seen twice, each time
    a few centimetres from where the estimate expects it: two corrections."""
    console = Console(root)
    console.control.localisation.use_markers({7: MARKER})
    path = console.sessions.start_recording()
    assert path is not None
    for tick in range(80):
        console.control.press(Intent.FORWARD_LEFT)
        if tick in SIGHTED_AT:
            pose = console.control.pose
            dx, dy = MARKER.x - pose.x, MARKER.y - pose.y
            bearing = math.atan2(dy, dx) - pose.heading + 0.01
            sighting = Observation(7, math.hypot(dx, dy) + 0.03, bearing, None, console.clock.now())
            console.control.localisation.sighted([sighting])
        console.tick()
    console.sessions.stop_recording()
    origin = read_meta(path)["clock_origin"]
    live = [(now - origin, telemetry.estimate) for now, telemetry in console.published
            if telemetry.estimate is not None]  # fmt: skip
    assert len(live) == 80
    return Recording(path, live, origin)


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Recording:
    return record_past_a_marker(tmp_path_factory.mktemp("recordings"))


def triple(pose: Pose) -> tuple[float, float, float]:
    return pose.x, pose.y, pose.heading


def test_the_recording_keeps_the_estimate_and_the_odometry_as_they_were_published(recording):
    read = open_estimates(recording.path)
    assert read.problems == []
    live = {round(offset, 3): estimate for offset, estimate in recording.live}
    for entry in read.entries:
        published = live[entry.offset]
        assert entry.pose == triple(published.pose)
        assert entry.odometry == triple(published.odometry)
        assert entry.covariance == published.covariance
        assert (entry.sigma_m, entry.sigma_heading, entry.ellipse) == (
            published.sigma_m, published.sigma_heading, published.ellipse)  # fmt: skip
        assert (entry.landmarks, entry.found, entry.seen) == (True, published.found, published.seen)
    # A modest rate: about one tick in four, never more than 0.2 s (and a tick) apart.
    offsets = [entry.offset for entry in read.entries]
    assert offsets[0] == 0.0 and len(offsets) < len(recording.live) / 3
    assert max(np.diff(offsets)) <= 0.2 + TICK + 1e-9
    # Each correction is written at the tick it happened, not up to 0.2 s later.
    corrected = {e.corrected_at for _, e in recording.live if e.corrected_at is not None}
    assert len(corrected) == len(SIGHTED_AT)
    for at in sorted(corrected):
        offset = at - recording.origin  # the loop's clock, as seconds into the session
        [first, *_] = [entry for entry in read.entries if entry.corrected_at == offset]
        assert first.offset == pytest.approx(offset, abs=1e-3)
    # And the estimate is no longer the odometry's: the corrections moved it.
    assert read.entries[-1].pose != read.entries[-1].odometry


def test_playback_shows_the_estimate_that_was_shown_live(recording, tmp_path):
    console = Console(tmp_path)
    assert console.sessions.start_playback(recording.path) is not None
    live_offsets = [offset for offset, _ in recording.live]
    compared = 0
    for _ in range(120):
        console.tick()
        telemetry = console.published[-1][1]
        if telemetry.playback is None:
            continue
        position = telemetry.playback.position
        index = bisect.bisect_right(live_offsets, position + 1e-9) - 1
        expected = recording.live[index][1].pose
        # The log keeps wheel readings to 5 decimals: the odometry redone from it, which
        # carries the estimate between two recorded ones, agrees to some micrometres.
        assert (telemetry.pose.x, telemetry.pose.y) == pytest.approx(
            (expected.x, expected.y), abs=1e-4)  # fmt: skip
        assert telemetry.pose.heading == pytest.approx(expected.heading, abs=1e-4)
        compared += 1
    assert compared > 60
    assert "playback finished; live again" in console.notes


def test_a_cut_off_estimate_is_reported_and_the_session_still_plays(recording, tmp_path):
    session = tmp_path / "cut"
    shutil.copytree(recording.path, session)
    path = session / "estimate.jsonl"
    text = path.read_text()
    lines = text.count("\n")
    path.write_text(text[: len(text) - 50])  # a power cut while writing the last one
    console = Console(tmp_path / "recordings")
    playback = console.sessions.start_playback(session)
    assert playback is not None
    assert f"{path}: line {lines}: incomplete last line, ignored" in console.notes
    assert len(playback.estimates) == lines - 1
    for _ in range(100):
        console.tick()
    assert "playback finished; live again" in console.notes


def test_a_session_recorded_before_the_filter_still_plays(tmp_path):
    session = tmp_path / "sample"
    shutil.copytree(SAMPLE, session)
    assert not (session / "estimate.jsonl").exists()
    console = Console(tmp_path / "recordings")
    playback = console.sessions.start_playback(session)
    assert playback is not None and playback.estimates == ()
    poses = []
    for _ in range(int(playback.duration / TICK) + 10):
        console.tick()
        telemetry = console.published[-1][1]
        if telemetry.playback is not None:
            poses.append(telemetry.pose)
    assert "playback finished; live again" in console.notes
    assert poses[-1].x > 0.5  # the odometry's pose, redone from the log, as before


def test_the_export_carries_the_recorded_covariance(recording, tmp_path, capsys):
    out = tmp_path / "session.mcap"
    assert main(["export", str(recording.path), str(out)]) == 0
    entries = open_estimates(recording.path).entries
    assert f"/pose_estimate {len(entries)}" in capsys.readouterr().out
    started = read_meta(recording.path)["started_unix"]
    live = {round(offset, 3): estimate for offset, estimate in recording.live}
    with out.open("rb") as file:
        messages = [
            (message.log_time, json.loads(message.data))
            for _, channel, message in make_reader(file).iter_messages()
            if channel.topic == "/pose_estimate"
        ]
    assert len(messages) == len(entries)
    for (log_time, body), entry in zip(messages, entries, strict=True):
        assert log_time == pytest.approx((started + entry.offset) * 1e9, abs=1_000)
        covariance = np.array(body["covariance"]).reshape(6, 6)
        kept = covariance[np.ix_([0, 1, 5], [0, 1, 5])]
        assert kept.tolist() == [list(row) for row in live[entry.offset].covariance]
        assert body["pose"]["position"]["x"] == live[entry.offset].pose.x
