"""Recording frames to MP4 in a background thread, with timestamps and odometry."""

from __future__ import annotations

import csv

import cv2
import numpy as np

from giraff_console.camera.association import SampleHistory
from giraff_console.camera.recorder import RecordedFrame, VideoRecorder
from giraff_console.camera.source import Frame, OpenCVCamera


def frame(i: int, size=(160, 120)) -> Frame:
    image = np.full((size[1], size[0], 3), (i * 7) % 256, dtype=np.uint8)
    return Frame(image, 100.0 + i * 0.1)


def test_n_frames_read_back_as_n_frames_of_the_right_size(tmp_path):
    path = tmp_path / "camera.mp4"
    recorder = VideoRecorder(path, (160, 120))
    for i in range(25):
        while not recorder.submit(RecordedFrame(frame(i), (i * 0.01, 0.0, 0.0))):
            pass  # the test must not lose frames: wait for room
    recorder.close()
    video = cv2.VideoCapture(str(path))
    count = 0
    while True:
        ok, image = video.read()
        if not ok:
            break
        assert image.shape == (120, 160, 3)
        count += 1
    assert count == 25 == recorder.written
    rows = list(csv.DictReader(path.with_suffix(".frames.csv").open()))
    assert len(rows) == 25
    assert float(rows[3]["captured_at"]) == 100.3 and float(rows[3]["x"]) == 0.03


def test_a_full_buffer_counts_its_drops(tmp_path):
    recorder = VideoRecorder(tmp_path / "camera.mp4", (1280, 960), buffers=1)
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
    path = tmp_path / "clip.mp4"
    recorder = VideoRecorder(path, (160, 120))
    for i in range(5):
        while not recorder.submit(RecordedFrame(frame(i * 30))):
            pass
    recorder.close()
    camera = OpenCVCamera(str(path))
    assert camera.open(800, 600) == (160, 120)  # a file keeps its own size
    frames = [camera.read() for _ in range(12)]
    camera.close()
    assert all(f is not None and f.size == (160, 120) for f in frames)
