"""A video cut off mid-segment, as kill -9 or a power loss leaves it, plays to the cut."""

from __future__ import annotations

import cv2
import numpy as np

from giraff_console.camera.recorder import RecordedFrame, VideoRecorder, segment_path
from giraff_console.camera.source import Frame
from giraff_console.recording.recorded_video import RecordedVideo, session_video, video_frames
from giraff_console.recording.session import SINGLE_FILE_VIDEO, VIDEO

SIZE = (160, 120)


def grey(i: int) -> np.ndarray:
    return np.full((SIZE[1], SIZE[0], 3), (i * 9) % 256, dtype=np.uint8)


def cut_video(folder, finished: int, unfinished: int) -> list[float]:
    """`finished` frames in closed segments, then a segment still being written.

    Returns every frame's time, as the frame index has them.
    """
    recorder = VideoRecorder(folder, SIZE)
    for i in range(finished):
        while not recorder.submit(RecordedFrame(Frame(grey(i), i * 0.1))):
            pass  # the test must not lose frames: wait for room
    recorder.close()
    # The segment a killed process was writing: its bytes on disk while still open,
    # before the index (moov) that closing writes.
    scratch = folder.parent / "open.mp4"
    writer = cv2.VideoWriter(str(scratch), cv2.VideoWriter_fourcc(*"mp4v"), 10.0, SIZE)
    for i in range(finished, finished + unfinished):
        writer.write(grey(i))
    path = segment_path(folder, finished)
    path.write_bytes(scratch.read_bytes())
    writer.release()
    assert not cv2.VideoCapture(str(path)).isOpened()
    return [i * 0.1 for i in range(finished + unfinished)]


def test_playback_holds_the_last_frame_before_the_cut(tmp_path):
    times = cut_video(tmp_path / VIDEO, finished=25, unfinished=8)
    position = [3.2]
    video = RecordedVideo(tmp_path / VIDEO, times, lambda: position[0], lambda: 0.0)
    assert video.open(800, 600) == SIZE
    frame = video.read()
    assert frame is not None and abs(float(frame.image.mean()) - grey(24).mean()) < 3
    assert len(video.times) == 25  # the index now ends where the video does
    position[0] = 0.55  # a seek back into an earlier segment
    frame = video.read()
    assert frame is not None and abs(float(frame.image.mean()) - grey(5).mean()) < 3
    video.close()
    assert video.read() is None


def test_every_finished_frame_is_read_in_order(tmp_path):
    cut_video(tmp_path / VIDEO, finished=25, unfinished=8)
    assert [number for number, _ in video_frames(tmp_path / VIDEO)] == list(range(25))


def test_a_session_without_segments_plays_its_single_file(tmp_path):
    assert session_video(tmp_path) is None
    writer = cv2.VideoWriter(
        str(tmp_path / SINGLE_FILE_VIDEO), cv2.VideoWriter_fourcc(*"mp4v"), 10.0, SIZE
    )
    for i in range(3):
        writer.write(grey(i))
    writer.release()
    assert session_video(tmp_path) == tmp_path / SINGLE_FILE_VIDEO
    assert [number for number, _ in video_frames(tmp_path / SINGLE_FILE_VIDEO)] == [0, 1, 2]
