"""A recorded session as one MCAP file, so that Foxglove and other robotics tools open it.

A session on disk (§3.2.1.1) is a control log, a video and a frame index, on two clocks,
and only this console plays it back. Exported, the controller transcript, the pose and
the camera share one wall-clock time line; Foxglove then shows each frame beside the
pose at its moment, the camera-odometry association of §3.3.1. Poses come from the
caller, who runs the robot's odometry over the log: robot/ is above this layer.

Messages are JSON with a JSON schema: Foxglove's own schemas for the pose and the
camera, and `giraff.ControllerLine` for the log lines. A session without a video has no
`/camera` channel at all, rather than an empty one.

`/pose` is the odometry's, as it always was, in the `odom` frame. A session recorded
with the pose filter (issue 14) also has `/pose_estimate`, the filter's estimate in the
`map` frame, at every recorded estimate (recording/estimates.py), with its covariance.
Foxglove has no JSON schema for a pose with a covariance, so `giraff.PoseWithCovarianceInFrame`
is `foxglove.PoseInFrame` with ROS's `PoseWithCovariance` covariance added: 36 numbers,
row-major, over (x, y, z, rotation about x, about y, about z). The filter estimates x, y
and the heading (the rotation about z); z, roll and pitch are not estimated, since the
robot stands on the floor, and their rows and columns are 0, as ROS's planar localisers
(amcl) leave them. The standard deviations the console shows, whether a marker has
found the robot and the markers seen and rejected go along.
"""

from __future__ import annotations

import base64
import contextlib
import heapq
import json
import math
import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import cv2
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import Writer

from giraff_console.private_files import open_private
from giraff_console.recording.control_log import LogRead
from giraff_console.recording.estimates import ESTIMATES, RecordedEstimate
from giraff_console.recording.playback import frame_times, open_estimates, open_log
from giraff_console.recording.recorded_video import session_video, video_frames
from giraff_console.recording.session import PoseSample, SessionError, read_meta

# A message as the streams produce it: seconds into the session, topic, JSON body.
Message = tuple[float, str, dict[str, Any]]


@dataclass(frozen=True)
class ExportSummary:
    """What was written, per topic, and what had to be left out."""

    channels: dict[str, int]
    problems: list[str]


def _object(title: str, **properties: dict[str, Any]) -> dict[str, Any]:
    return {"title": title, "type": "object", "properties": properties}


def _numbers(title: str, *names: str) -> dict[str, Any]:
    return _object(title, **{name: {"type": "number"} for name in names})


_STRING = {"type": "string"}
_TIME = _object("time", sec={"type": "integer", "minimum": 0},
                nsec={"type": "integer", "minimum": 0, "maximum": 999_999_999})  # fmt: skip
_POSE = _object(
    "foxglove.Pose",
    position=_numbers("foxglove.Vector3", "x", "y", "z"),
    orientation=_numbers("foxglove.Quaternion", "x", "y", "z", "w"),
)
_IDS = {"type": "array", "items": {"type": "integer"}}
# The filter's (x, y, heading) in ROS's (x, y, z, roll, pitch, yaw) order.
_AXES = (0, 1, 5)
SCHEMAS = {
    "/controller": _object(
        "giraff.ControllerLine",
        timestamp=_TIME,
        offset={"type": "number", "description": "seconds into the session"},
        flag={"type": "string", "description": "S set, G get, C command, space the poll"},
        command=_STRING,
        reply=_STRING,
        automatic={"type": "boolean"},
    ),
    "/pose": _object("foxglove.PoseInFrame", timestamp=_TIME, frame_id=_STRING, pose=_POSE),
    "/pose_estimate": _object(
        "giraff.PoseWithCovarianceInFrame",
        timestamp=_TIME,
        frame_id=_STRING,
        pose=_POSE,
        covariance={
            "type": "array",
            "items": {"type": "number"},
            "minItems": 36,
            "maxItems": 36,
            "description": "row-major 6x6 over x, y, z, rotation about x, y, z (ROS's "
            "PoseWithCovariance); z, roll and pitch are not estimated and are 0",
        },
        sigma_m={"type": "number", "description": "position std dev, worst direction, m"},
        sigma_heading={"type": "number", "description": "heading std dev, radians"},
        found={"type": "boolean", "description": "a marker has placed or confirmed the pose"},
        seen={**_IDS, "description": "markers used in the last 5 s"},
        rejected={**_IDS, "description": "markers the gate rejected in the last 5 s"},
    ),
    # Foxglove's JSON encoding carries bytes as base64 text.
    "/camera": _object(
        "foxglove.CompressedImage",
        timestamp=_TIME,
        frame_id=_STRING,
        format=_STRING,
        data={"type": "string", "contentEncoding": "base64"},
    ),
}


def export_session(session: Path, out: Path, poses: Iterable[PoseSample], *,
                   jpeg_quality: int = 80) -> ExportSummary:  # fmt: skip
    """Write `session` to the MCAP file `out`; SessionError if it cannot be read or written.

    The file is written beside `out` under a temporary name and renamed at the end, so
    a failure part way leaves no half file under the real name.
    """
    # A directory of ours, or a log file of the original console's.
    log_path, log = open_log(session)
    if not log.entries:
        raise SessionError(f"nothing to export: {log_path} has no log lines")
    problems = [f"control.log {problem}" for problem in log.problems]
    streams = {"/controller": _controller(log), "/pose": _poses(poses)}
    estimates = open_estimates(session)
    problems += [f"{ESTIMATES} {problem}" for problem in estimates.problems]
    if estimates.entries:
        streams["/pose_estimate"] = _estimates(estimates.entries)
    video = session_video(session)
    if video is not None:
        times = frame_times(session, log)
        streams["/camera"] = _frames(video, times, jpeg_quality, problems)
    start = read_meta(session).get("started_unix")
    if not isinstance(start, int | float):
        # An original console's log: it was last written at its last line.
        start = log_path.stat().st_mtime - log.duration
    temp = out.with_name(f".{out.name}.{os.getpid()}.part")
    try:
        with open_private(temp, "wb") as file:
            # In time order overall, so that chunks do not overlap in time.
            merged = heapq.merge(*streams.values(), key=lambda message: message[0])
            counts = _write(file, start, list(streams), merged)
        temp.replace(out)
    except OSError as error:
        raise SessionError(f"cannot write {out}: {error.strerror or error}") from None
    finally:
        # Where it could not be written, it cannot be removed either: nothing to do.
        with contextlib.suppress(OSError):
            temp.unlink(missing_ok=True)
    return ExportSummary(counts, problems)


def _write(file: IO[bytes], start: float, topics: list[str],
           messages: Iterable[Message]) -> dict[str, int]:  # fmt: skip
    writer = Writer(file)
    writer.start()
    channels: dict[str, int] = {}
    for topic in topics:
        schema = SCHEMAS[topic]
        schema_id = writer.register_schema(
            schema["title"], SchemaEncoding.JSONSchema, json.dumps(schema).encode()
        )
        channels[topic] = writer.register_channel(topic, MessageEncoding.JSON, schema_id)
    counts = dict.fromkeys(topics, 0)
    for offset, topic, body in messages:
        nanoseconds = round((start + offset) * 1e9)
        stamp = {"sec": nanoseconds // 1_000_000_000, "nsec": nanoseconds % 1_000_000_000}
        data = json.dumps({"timestamp": stamp, **body}, separators=(",", ":")).encode()
        writer.add_message(channels[topic], nanoseconds, data, nanoseconds, counts[topic])
        counts[topic] += 1
    writer.finish()
    return counts


def _controller(log: LogRead) -> Iterator[Message]:
    for entry in log.entries:
        yield entry.offset, "/controller", {
            "offset": entry.offset, "flag": entry.flag, "command": entry.command,
            "reply": entry.reply, "automatic": entry.automatic,
        }  # fmt: skip


def _poses(poses: Iterable[PoseSample]) -> Iterator[Message]:
    for pose in sorted(poses, key=lambda pose: pose.offset):
        body = {"frame_id": "odom", "pose": _pose(pose.x, pose.y, pose.heading)}
        yield pose.offset, "/pose", body


def _estimates(estimates: Iterable[RecordedEstimate]) -> Iterator[Message]:
    for estimate in estimates:
        body = {
            "frame_id": "map",
            "pose": _pose(*estimate.pose),
            "covariance": covariance_6x6(estimate.covariance),
            "sigma_m": estimate.sigma_m,
            "sigma_heading": estimate.sigma_heading,
            "found": estimate.found,
            "seen": list(estimate.seen),
            "rejected": list(estimate.rejected),
        }
        yield estimate.offset, "/pose_estimate", body


def covariance_6x6(covariance: tuple[tuple[float, float, float], ...]) -> list[float]:
    """(x, y, heading)'s 3x3 covariance as ROS's row-major 6x6 over (x, y, z, roll, pitch,
    yaw); z, roll and pitch are not estimated: 0."""
    full = [0.0] * 36
    for row, axis in enumerate(_AXES):
        for column, other in enumerate(_AXES):
            full[axis * 6 + other] = covariance[row][column]
    return full


def _pose(x: float, y: float, heading: float) -> dict[str, Any]:
    # A turn of `heading` about +z, as a unit quaternion.
    half = heading / 2
    turn = {"x": 0.0, "y": 0.0, "z": math.sin(half), "w": math.cos(half)}
    return {"position": {"x": x, "y": y, "z": 0.0}, "orientation": turn}


def _frames(path: Path, times: list[float], quality: int, problems: list[str]) -> Iterator[Message]:
    """Each frame at its recorded time (camera.frames.csv), re-encoded as JPEG."""
    untimed, read = 0, 0
    for index, image in video_frames(path):
        read += 1
        if index >= len(times):  # the frame index was cut short
            untimed += 1
            continue
        ok, jpeg = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])
        if not ok:
            problems.append(f"video: frame {index} could not be encoded as JPEG; skipped")
            continue
        data = base64.b64encode(jpeg.tobytes()).decode("ascii")
        yield times[index], "/camera", {"frame_id": "camera", "format": "jpeg", "data": data}
    if not read:
        problems.append(f"video: cannot read {path.name}; no frames exported")
    if untimed:
        problems.append(f"video: {untimed} frames without a time; skipped")
