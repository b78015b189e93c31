"""Exporting a recorded session to MCAP, read back with the mcap library itself."""

from __future__ import annotations

import base64
import json
import math
import os
from pathlib import Path

import cv2
import numpy as np
import pytest
from mcap.reader import make_reader

from giraff_console.camera.recorder import RecordedFrame, VideoRecorder
from giraff_console.camera.source import Frame
from giraff_console.recording.control_log import LogEntry, format_entry
from giraff_console.recording.estimates import RecordedEstimate, format_estimate
from giraff_console.recording.mcap_export import export_session
from giraff_console.recording.session import VIDEO, PoseSample, SessionError

STARTED_UNIX = 1_700_000_000.25
CLOCK_ORIGIN = 5000.0
SIZE = (160, 120)
FRAME_OFFSETS = [0.15, 0.35, 0.55, 0.75, 0.95]
ENTRIES = [
    LogEntry(0.010, "S", "v", "OK", "0.3"),
    LogEntry(0.100, " ", "bulk_data", "mode=0 p=0"),
    LogEntry(0.200, "G", "v", "0.3"),
    LogEntry(0.300, "C", "home", ""),
    LogEntry(0.400, " ", "bulk_data", "mode=0 p=10"),
    LogEntry(1.000, "S", "p", "OK", "0"),
]
POSES = [PoseSample(i * 0.25, i * 0.1, 0.0, i * math.pi / 8) for i in range(5)]


def make_session(root: Path, video: bool = True) -> Path:
    session = root / "20240101_120000"
    session.mkdir()
    lines = "".join(format_entry(entry) + "\n" for entry in ENTRIES)
    (session / "control.log").write_text(lines)
    meta = {"started_unix": STARTED_UNIX, "clock_origin": CLOCK_ORIGIN}
    (session / "meta.json").write_text(json.dumps(meta))
    if video:
        recorder = VideoRecorder(session / VIDEO, SIZE)
        for i, offset in enumerate(FRAME_OFFSETS):
            image = np.full((SIZE[1], SIZE[0], 3), i * 40, dtype=np.uint8)
            while not recorder.submit(RecordedFrame(Frame(image, CLOCK_ORIGIN + offset))):
                pass  # the test must not lose frames: wait for room
        recorder.close()
    return session


def read_back(path: Path):
    with path.open("rb") as file:
        reader = make_reader(file)
        summary = reader.get_summary()
        messages = [(channel.topic, message) for _, channel, message in reader.iter_messages()]
    return summary, messages


def by_topic(messages, topic: str):
    return [message for name, message in messages if name == topic]


def test_each_topic_is_json_with_the_schema_foxglove_knows(tmp_path):
    out = tmp_path / "session.mcap"
    export_session(make_session(tmp_path), out, POSES)
    summary, _ = read_back(out)
    schemas = {
        channel.topic: (summary.schemas[channel.schema_id], channel.message_encoding)
        for channel in summary.channels.values()
    }
    assert set(schemas) == {"/pose", "/controller", "/camera"}
    assert schemas["/pose"][0].name == "foxglove.PoseInFrame"
    assert schemas["/controller"][0].name == "giraff.ControllerLine"
    assert schemas["/camera"][0].name == "foxglove.CompressedImage"
    for schema, encoding in schemas.values():
        assert encoding == "json" and schema.encoding == "jsonschema"
        assert json.loads(schema.data)["title"] == schema.name


def test_one_message_per_log_line_pose_and_frame(tmp_path):
    out = tmp_path / "session.mcap"
    result = export_session(make_session(tmp_path), out, POSES)
    _, messages = read_back(out)
    expected = {"/controller": len(ENTRIES), "/pose": len(POSES), "/camera": len(FRAME_OFFSETS)}
    assert {topic: len(by_topic(messages, topic)) for topic in expected} == expected
    assert result.channels == expected and result.problems == []
    lines = [json.loads(message.data) for message in by_topic(messages, "/controller")]
    assert [line["command"] for line in lines[:4]] == [
        "set v 0.3",
        "get bulk_data",
        "get v",
        "home",
    ]
    assert [line["automatic"] for line in lines[:3]] == [False, True, False]


def test_a_camera_message_decodes_to_a_jpeg_of_the_recorded_size(tmp_path):
    out = tmp_path / "session.mcap"
    export_session(make_session(tmp_path), out, POSES)
    _, messages = read_back(out)
    image_message = json.loads(by_topic(messages, "/camera")[2].data)
    assert image_message["format"] == "jpeg" and image_message["frame_id"] == "camera"
    jpeg = np.frombuffer(base64.b64decode(image_message["data"]), dtype=np.uint8)
    image = cv2.imdecode(jpeg, cv2.IMREAD_COLOR)
    assert image.shape == (SIZE[1], SIZE[0], 3)
    assert abs(int(image.mean()) - 80) <= 3  # the third frame, grey level 2 * 40


def test_times_run_forward_per_topic_from_the_session_start(tmp_path):
    out = tmp_path / "session.mcap"
    export_session(make_session(tmp_path), out, POSES)
    _, messages = read_back(out)
    offsets = {
        "/controller": [entry.offset for entry in ENTRIES],
        "/pose": [pose.offset for pose in POSES],
        "/camera": FRAME_OFFSETS,
    }
    for topic, expected in offsets.items():
        found = by_topic(messages, topic)
        times = [message.log_time for message in found]
        assert times == sorted(times), topic
        for message, offset in zip(found, expected, strict=True):
            assert abs(message.log_time - (STARTED_UNIX + offset) * 1e9) < 1_000, topic
            assert message.publish_time == message.log_time
            stamp = json.loads(message.data)["timestamp"]
            assert stamp["sec"] * 1_000_000_000 + stamp["nsec"] == message.log_time


def test_the_pose_turns_about_z_by_the_heading(tmp_path):
    out = tmp_path / "session.mcap"
    turned = [PoseSample(0.5, 1.0, 2.0, math.pi / 2)]
    export_session(make_session(tmp_path, video=False), out, turned)
    _, messages = read_back(out)
    pose = json.loads(by_topic(messages, "/pose")[0].data)
    assert pose["frame_id"] == "odom"
    assert pose["pose"]["position"] == {"x": 1.0, "y": 2.0, "z": 0.0}
    q = pose["pose"]["orientation"]
    assert (q["x"], q["y"]) == (0.0, 0.0)
    assert q["z"] == pytest.approx(math.sqrt(0.5)) and q["w"] == pytest.approx(math.sqrt(0.5))


def test_a_session_without_video_has_no_camera_channel(tmp_path):
    out = tmp_path / "session.mcap"
    result = export_session(make_session(tmp_path, video=False), out, POSES)
    summary, _ = read_back(out)
    assert {channel.topic for channel in summary.channels.values()} == {"/pose", "/controller"}
    assert result.channels == {"/controller": len(ENTRIES), "/pose": len(POSES)}


def test_frames_the_index_does_not_time_are_reported_and_left_out(tmp_path):
    session = make_session(tmp_path)
    index = session / "camera.frames.csv"
    index.write_text("".join(index.read_text().splitlines(keepends=True)[:3]))  # two frames
    result = export_session(session, tmp_path / "session.mcap", POSES)
    assert result.channels["/camera"] == 2
    assert result.problems == ["video: 3 frames without a time; skipped"]


def test_a_corrupt_log_line_is_reported_and_the_rest_exported(tmp_path):
    session = make_session(tmp_path, video=False)
    log = session / "control.log"
    lines = log.read_text().splitlines(keepends=True)
    log.write_text("".join([*lines[:2], "garbage\n", *lines[2:]]))
    result = export_session(session, tmp_path / "session.mcap", POSES)
    assert result.channels["/controller"] == len(ENTRIES)
    assert len(result.problems) == 1 and result.problems[0].startswith("control.log line 3: ")


def test_an_original_log_without_meta_ends_at_its_modification_time(tmp_path):
    session = make_session(tmp_path, video=False)
    (session / "meta.json").unlink()
    os.utime(session / "control.log", (STARTED_UNIX + 1.0, STARTED_UNIX + 1.0))
    out = tmp_path / "session.mcap"
    export_session(session, out, [])
    _, messages = read_back(out)
    last = by_topic(messages, "/controller")[-1]  # at 1.000 s, when the file was written
    assert abs(last.log_time - (STARTED_UNIX + 1.0) * 1e9) < 1_000


def test_a_missing_session_or_control_log_is_a_session_error(tmp_path):
    with pytest.raises(SessionError, match="no session log at"):
        export_session(tmp_path / "nowhere", tmp_path / "out.mcap", POSES)
    with pytest.raises(SessionError, match="cannot read"):
        export_session(tmp_path / ("x" * 300), tmp_path / "out.mcap", POSES)  # name too long
    not_a_log = tmp_path / "notes.txt"
    not_a_log.write_text("shopping list\nmilk\n")
    with pytest.raises(SessionError, match="no log lines"):
        export_session(not_a_log, tmp_path / "out.mcap", POSES)
    session = make_session(tmp_path, video=False)
    (session / "control.log").unlink()
    with pytest.raises(SessionError, match="no session log"):
        export_session(session, tmp_path / "out.mcap", POSES)
    assert not (tmp_path / "out.mcap").exists()


def test_an_output_folder_that_does_not_exist_is_a_session_error(tmp_path):
    session = make_session(tmp_path)
    before = sorted(tmp_path.rglob("*"))
    with pytest.raises(SessionError, match="cannot write"):
        export_session(session, tmp_path / "missing" / "session.mcap", POSES)
    assert sorted(tmp_path.rglob("*")) == before


def test_a_failure_after_writing_leaves_no_temporary_file(tmp_path):
    session = make_session(tmp_path)
    out = tmp_path / "taken"
    out.mkdir()  # the finished file cannot be renamed onto a folder
    with pytest.raises(SessionError, match="cannot write"):
        export_session(session, out, POSES)
    assert sorted(path.name for path in tmp_path.iterdir()) == ["20240101_120000", "taken"]
    assert list(out.iterdir()) == []


# -- the pose filter's estimate (issue 14) ---------------------------------------------

COVARIANCE = ((0.0025, 1e-4, -3e-4), (1e-4, 0.0036, 2e-4), (-3e-4, 2e-4, 0.0012))
ESTIMATES = [
    RecordedEstimate(
        offset=0.2 * i,
        pose=(1.0 + 0.1 * i, 2.0, math.pi / 2),
        odometry=(0.1 * i, 0.0, 0.0),
        covariance=tuple(tuple(v * (i + 1) for v in row) for row in COVARIANCE),  # type: ignore[arg-type]
        sigma_m=0.05 * (i + 1),
        sigma_heading=0.03,
        ellipse=(0.05, 0.04, 0.3),
        landmarks=True,
        found=i > 0,
        seen=(7,) if i > 0 else (),
        corrected_at=0.2 if i > 0 else None,
    )
    for i in range(4)
]


def with_estimates(session: Path) -> Path:
    lines = "".join(format_estimate(estimate) + "\n" for estimate in ESTIMATES)
    (session / "estimate.jsonl").write_text(lines)
    return session


def test_the_estimate_goes_out_with_its_covariance_beside_the_odometrys_pose(tmp_path):
    out = tmp_path / "session.mcap"
    result = export_session(with_estimates(make_session(tmp_path)), out, POSES)
    assert result.channels["/pose_estimate"] == len(ESTIMATES) and result.problems == []
    summary, messages = read_back(out)
    schemas = {c.topic: summary.schemas[c.schema_id] for c in summary.channels.values()}
    assert schemas["/pose_estimate"].name == "giraff.PoseWithCovarianceInFrame"
    assert schemas["/pose"].name == "foxglove.PoseInFrame"  # the odometry's, as before
    assert len(by_topic(messages, "/pose")) == len(POSES)
    found = by_topic(messages, "/pose_estimate")
    for message, recorded in zip(found, ESTIMATES, strict=True):
        assert abs(message.log_time - (STARTED_UNIX + recorded.offset) * 1e9) < 1_000
        body = json.loads(message.data)
        assert body["frame_id"] == "map"
        assert body["pose"]["position"] == dict(zip("xyz", (*recorded.pose[:2], 0.0), strict=True))
        assert body["pose"]["orientation"]["z"] == pytest.approx(math.sqrt(0.5))
        # Row-major 6x6 over x, y, z, roll, pitch, yaw: the filter's x, y and heading are
        # rows and columns 0, 1 and 5; z, roll and pitch, which it does not estimate, 0.
        expected = np.zeros((6, 6))
        expected[np.ix_([0, 1, 5], [0, 1, 5])] = recorded.covariance
        assert body["covariance"] == expected.flatten().tolist()
        assert (body["sigma_m"], body["found"], body["seen"]) == (
            recorded.sigma_m,
            recorded.found,
            list(recorded.seen),
        )


def test_a_session_recorded_before_the_filter_has_no_estimate_channel(tmp_path):
    out = tmp_path / "session.mcap"
    result = export_session(make_session(tmp_path, video=False), out, POSES)
    summary, _ = read_back(out)
    assert "/pose_estimate" not in {channel.topic for channel in summary.channels.values()}
    assert "/pose_estimate" not in result.channels


def test_a_cut_off_estimate_is_reported_and_the_rest_exported(tmp_path):
    session = with_estimates(make_session(tmp_path, video=False))
    path = session / "estimate.jsonl"
    text = path.read_text()
    path.write_text(text[: len(text) - 30])  # a crash while writing the last one
    result = export_session(session, tmp_path / "session.mcap", POSES)
    assert result.channels["/pose_estimate"] == len(ESTIMATES) - 1
    assert result.problems == ["estimate.jsonl line 4: incomplete last line, ignored"]
