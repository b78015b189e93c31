"""Recording frames to MP4 segments in a background thread, with timestamps and odometry."""

from __future__ import annotations

import csv
import time

import numpy as np

from giraff_console.camera.association import SampleHistory
from giraff_console.camera.recorder import RecordedFrame, VideoRecorder, segment_path
from giraff_console.camera.source import Frame, OpenCVCamera
from giraff_console.recording.recorded_video import video_frames


def frame(i: int, size=(160, 120)) -> Frame:
    image = np.full((size[1], size[0], 3), (i * 7) % 256, dtype=np.uint8)
    return Frame(image, 100.0 + i * 0.1)


def record(recorder: VideoRecorder, numbers: range) -> None:
    for i in numbers:
        while not recorder.submit(RecordedFrame(frame(i), (i * 0.01, 0.0, 0.0))):
            pass  # the test must not lose frames: wait for room


def readable(path, count: int, timeout: float = 10.0) -> list[tuple[int, np.ndarray]]:
    """The frames OpenCV reads once `count` of them can be read; fails after `timeout`."""
    deadline = time.monotonic() + timeout
    while True:
        frames = list(video_frames(path))
        if len(frames) >= count or time.monotonic() > deadline:
            return frames
        time.sleep(0.05)


def test_n_frames_read_back_as_n_frames_of_the_right_size(tmp_path):
    path = tmp_path / "camera"
    recorder = VideoRecorder(path, (160, 120))
    record(recorder, range(25))
    recorder.close()
    frames = list(video_frames(path))
    assert [number for number, _ in frames] == list(range(25)) == list(range(recorder.written))
    assert all(image.shape == (120, 160, 3) for _, image in frames)
    # Frames 0.1 s apart: a segment a second, each named by its first frame.
    assert sorted(path.iterdir()) == [segment_path(path, first) for first in (0, 10, 20)]
    rows = list(csv.DictReader(path.with_suffix(".frames.csv").open()))
    assert len(rows) == 25
    assert float(rows[3]["captured_at"]) == 100.3 and float(rows[3]["x"]) == 0.03


def test_a_full_buffer_counts_its_drops(tmp_path):
    recorder = VideoRecorder(tmp_path / "camera", (1280, 960), buffers=1)
    submitted = 60
    for i in range(submitted):
        recorder.submit(RecordedFrame(frame(i, (1280, 960))))
    recorder.close()
    assert recorder.dropped > 0
    assert recorder.written + recorder.dropped == submitted


def test_each_frame_takes_the_odometry_sample_nearest_in_time():
    history = SampleHistory()
    assert history.nearest(1.0) is None
    for i in range(10):
        history.add(i * 0.05, (i * 0.02, 0.0, 0.0))
    assert history.nearest(0.11) == (0.04, 0.0, 0.0)  # 0.10 is nearer than 0.15
    assert history.nearest(0.14) == (0.06, 0.0, 0.0)
    assert history.nearest(-1.0) == (0.0, 0.0, 0.0)
    assert history.nearest(99.0) == (0.18, 0.0, 0.0)


def test_a_video_file_plays_as_a_camera_and_loops(tmp_path):
    recorder = VideoRecorder(tmp_path / "clip", (160, 120))
    record(recorder, range(5))  # half a second: one segment
    recorder.close()
    camera = OpenCVCamera(str(segment_path(tmp_path / "clip", 0)))
    assert camera.open(800, 600) == (160, 120)  # a file keeps its own size
    frames = [camera.read() for _ in range(12)]
    camera.close()
    assert all(f is not None and f.size == (160, 120) for f in frames)


def test_finished_segments_are_readable_while_the_recording_goes_on(tmp_path):
    # What a kill -9 leaves: the recorder is never closed, only its segment is lost.
    path = tmp_path / "camera"
    recorder = VideoRecorder(path, (160, 120), segment_seconds=1.0)
    try:
        record(recorder, range(25))
        frames = readable(path, 20)
        assert [number for number, _ in frames] == list(range(20))
        for number, image in frames:
            # mp4v is lossy: each frame is still the grey it was recorded as.
            assert abs(float(image.mean()) - (number * 7) % 256) < 3
        assert recorder.error is None
    finally:
        recorder.close()
    assert len(list(video_frames(path))) == 25


def test_a_pause_in_the_camera_makes_the_frames_so_far_readable(tmp_path):
    path = tmp_path / "camera"
    recorder = VideoRecorder(path, (160, 120), segment_seconds=0.2)
    try:
        record(recorder, range(1))  # one frame, then the camera stops giving any
        assert [number for number, _ in readable(path, 1)] == [0]
        record(recorder, range(1, 3))  # it comes back: a new segment
    finally:
        recorder.close()
    assert [number for number, _ in video_frames(path)] == [0, 1, 2]
    assert segment_path(path, 1).is_file()
