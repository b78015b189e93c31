"""Benchmark: the camera pipeline at 800x600, stage by stage, and the renderer against rich-pixels.

Stages: capture (the synthetic camera), FAST, recording (MP4 in its own thread) and the
half-block terminal rendering at 100x37 cells. The full pipeline then runs at its 10 fps
cap for a while, recording all the time, to measure the rate reached, the share of one
core it takes (process CPU time over wall time), and the frames the recorder dropped.
rich-pixels, rendering the same frames to the same size in the same run, is the peer.

Usage: python bench/camera.py [--seconds S]   (rich-pixels: pip install '.[bench]')
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

import cv2
from PIL import Image

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from giraff_console.camera.feed import CameraFeed
from giraff_console.camera.halfblock import HalfBlockRenderer
from giraff_console.camera.processors import FastCorners, Pipeline
from giraff_console.camera.recorder import RecordedFrame, VideoRecorder
from giraff_console.camera.source import Frame
from giraff_console.sim.camera import WorldCamera
from giraff_console.sim.drive import TruePose
from giraff_console.sim.world import demo_world

SIZE = (800, 600)
CELLS = (100, 37)


def poses(n: int) -> list[TruePose]:
    """A walk through the demo world, turning as it goes."""
    return [TruePose(0.5 + 0.05 * i, 0.3 * math.sin(i / 10), 0.02 * i) for i in range(n)]


def stage_times(frames: int) -> dict[str, float]:
    camera = WorldCamera(demo_world())
    pipeline = Pipeline([FastCorners()])
    pipeline.toggle("fast")
    renderer = HalfBlockRenderer(truecolor=True)
    times: dict[str, list[float]] = {"capture": [], "fast": [], "encode": [], "render": [],
                                     "rich-pixels": []}  # fmt: skip
    with tempfile.TemporaryDirectory() as scratch:
        writer = cv2.VideoWriter(f"{scratch}/v.mp4", cv2.VideoWriter_fourcc(*"mp4v"), 10, SIZE)
        for pose in poses(frames):
            start = time.perf_counter()
            image = camera.render(pose, *SIZE)
            times["capture"].append(time.perf_counter() - start)
            start = time.perf_counter()
            processed = pipeline.run(image)
            times["fast"].append(time.perf_counter() - start)
            start = time.perf_counter()
            writer.write(image)
            times["encode"].append(time.perf_counter() - start)
            start = time.perf_counter()
            renderer.render(processed.image, *CELLS)
            times["render"].append(time.perf_counter() - start)
            start = time.perf_counter()
            rich_pixels(processed.image)
            times["rich-pixels"].append(time.perf_counter() - start)
        writer.release()
    return {name: statistics.median(values) * 1e3 for name, values in times.items()}


def rich_pixels(image) -> None:
    from rich_pixels import Pixels

    rgb = cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
    Pixels.from_image(Image.fromarray(rgb), resize=(CELLS[0], CELLS[1] * 2))


def full_pipeline(seconds: float) -> tuple[float, float, int, int]:
    """Frames per second, share of one core, frames written and dropped."""
    camera = WorldCamera(demo_world())
    walk = iter(poses(10_000))
    pipeline = Pipeline([FastCorners()])
    pipeline.toggle("fast")
    with tempfile.TemporaryDirectory() as scratch:
        recorder = VideoRecorder(Path(scratch) / "camera", SIZE)

        class Recorded:
            name = "synthetic camera"

            def open(self, width, height):
                return width, height

            def read(self):
                frame = Frame(camera.render(next(walk), *SIZE), time.monotonic())
                recorder.submit(RecordedFrame(frame, (0.0, 0.0, 0.0)))
                return frame

            def close(self):
                pass

        shown = []
        feed = CameraFeed(Recorded(), SIZE, pipeline, HalfBlockRenderer(), shown.append)
        feed.set_cells(*CELLS)
        cpu, wall = time.process_time(), time.perf_counter()
        feed.start()
        time.sleep(seconds)
        feed.stop()
        recorder.close()
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        return len(shown) / wall, cpu / wall, recorder.written, recorder.dropped


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="full-pipeline run")
    args = parser.parse_args()
    stages = stage_times(60)
    print(f"camera pipeline at {SIZE[0]}x{SIZE[1]}, terminal view {CELLS[0]}x{CELLS[1]} cells")
    for name, ms in stages.items():
        print(f"  {name:<12}{ms:8.2f} ms/frame (median of 60)")
    ratio = stages["rich-pixels"] / stages["render"]
    print(f"  half-block renderer {ratio:.1f}x faster than rich-pixels")
    fps, share, written, dropped = full_pipeline(args.seconds)
    print(f"full pipeline for {args.seconds:.0f} s: {fps:.1f} fps, {share:.0%} of one core, "
          f"{written} frames recorded, {dropped} dropped")  # fmt: skip


if __name__ == "__main__":
    main()
