"""Benchmark: the camera pipeline at 800x600, stage by stage, and the renderer against rich-pixels.

Stages: capture (the synthetic camera in the example care home, walking past its wall
markers; "(unmarked)" is the same walk with the markers taken off the walls), FAST,
marker detection with each marker's pose (issue 14), recording (MP4 in its own thread)
and the half-block terminal rendering at 100x37 cells; then how far the sightings'
distances and bearings are from the truth. The full pipeline then runs at its 10 fps
cap for a while, FAST and markers on, recording all the time, to measure the rate
reached, the share of one core it takes (process CPU time over wall time), and the
frames the recorder dropped; then as the console runs it (FAST, markers, the half-block
view; no recording) with no cap, to measure how many frames a second it could take.
Medians are of wall time; CPU time beside them (all threads: OpenCV's detector uses more
than one), since other work on the machine stretches wall time but not CPU time.

Peers, measured on the same frames in the same run: rich-pixels for the terminal
rendering; OpenCV's ArucoDetector as it comes (its default parameters, every marker of
the family, no pose) for the marker detection.

`--busy N` runs N busy loops (`python3 -c 'while 1: pass'`) beside the benchmark, as
issue 14 asks the console to hold 10 fps beside other work; they are ended afterwards.

Usage: python bench/camera.py [--seconds S] [--busy N]   (rich-pixels: pip install '.[bench]')
"""

from __future__ import annotations

import argparse
import importlib.util
import itertools
import math
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from giraff_console.camera.feed import CameraFeed
from giraff_console.camera.halfblock import HalfBlockRenderer
from giraff_console.camera.markers import CameraIntrinsics, MarkerDetector, aruco_dictionary
from giraff_console.camera.processors import FastCorners, Pipeline
from giraff_console.camera.recorder import RecordedFrame, VideoRecorder
from giraff_console.camera.source import Frame
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.runtime.sim_site import plan_world
from giraff_console.sim.camera import WorldCamera
from giraff_console.sim.drive import TruePose
from giraff_console.sim.world import World

SIZE = (800, 600)
CELLS = (100, 37)
EXAMPLE = Path(__file__).resolve().parents[1] / "giraff_console/floorplans/care-home.yaml"
HAVE_RICH_PIXELS = importlib.util.find_spec("rich_pixels") is not None


def building() -> tuple[WorldCamera, MarkerDetector]:
    """The example care home as the synthetic camera sees it, and a detector for its
    markers with the camera's own intrinsics."""
    landmarks = load_floorplan(EXAMPLE).landmarks
    camera = WorldCamera(plan_world(load_floorplan(EXAMPLE)))

    def intrinsics(width: int, height: int) -> CameraIntrinsics:
        known = camera.intrinsics(width, height)
        return CameraIntrinsics(known.fx, known.fy, known.cx, known.cy, known.distortion)

    ids = [marker.id for marker in landmarks.markers]
    return camera, MarkerDetector(landmarks.family, landmarks.size, intrinsics, ids=ids)


def poses(camera: WorldCamera, n: int) -> list[TruePose]:
    """A walk past the building's markers: towards each in turn from 3 m to 1 m off,
    from a little to one side and turned a little away, so that it sits anywhere in the
    picture; the walls, posters and other markers around it come with it."""
    markers = camera.world.markers
    walk = []
    for i in range(n):
        marker = markers[(i // 10) % len(markers)]
        step = i % 10
        reach = 3.0 - 0.2 * step
        slant = math.radians(20 * math.sin(i / 3))
        x = marker.x + reach * math.cos(marker.facing + slant)
        y = marker.y + reach * math.sin(marker.facing + slant)
        heading = marker.facing + slant + math.pi + math.radians(15 * math.cos(i / 4))
        walk.append(TruePose(x, y, heading))
    return walk


def stage_times(frames: int) -> tuple[dict[str, tuple[float, float]], float, list[tuple]]:
    """Median wall and CPU milliseconds per stage, the markers found per frame, and each
    sighting's true distance with its distance and bearing errors."""
    camera, detector = building()
    where = {marker.id: marker for marker in camera.world.markers}
    errors = []
    fast = FastCorners()
    renderer = HalfBlockRenderer(truecolor=True)
    stock = cv2.aruco.ArucoDetector(
        aruco_dictionary(detector.family), cv2.aruco.DetectorParameters()
    )
    names = ["capture", "(unmarked)", "fast", "markers", "(stock)", "encode", "render",
             "rich-pixels"]  # fmt: skip
    # The same building without its markers: what drawing them costs the capture.
    unmarked = WorldCamera(World(camera.world.walls))
    times: dict[str, list[tuple[float, float]]] = {name: [] for name in names}
    found = 0

    def timed(name, work):
        wall, cpu = time.perf_counter(), time.process_time()
        result = work()
        times[name].append((time.perf_counter() - wall, time.process_time() - cpu))
        return result

    with tempfile.TemporaryDirectory() as scratch:
        writer = cv2.VideoWriter(f"{scratch}/v.mp4", cv2.VideoWriter_fourcc(*"mp4v"), 10, SIZE)
        for pose in poses(camera, frames):
            image = timed("capture", lambda: camera.render(pose, *SIZE))  # noqa: B023
            timed("(unmarked)", lambda: unmarked.render(pose, *SIZE))  # noqa: B023
            # The grey frame is made once for all processors; counted with FAST, as before.
            grey, shown = timed("fast", lambda: corners(fast, image))  # noqa: B023
            seen = timed("markers", lambda: detector.process(shown, grey, 0.0))  # noqa: B023
            timed("(stock)", lambda: stock.detectMarkers(grey))  # noqa: B023
            found += len(seen.data["markers"])
            for sighting in seen.data["markers"]:
                marker = where[sighting.id]
                dx, dy = marker.x - pose.x, marker.y - pose.y
                bearing = math.atan2(dy, dx) - pose.heading
                bearing_error = (sighting.bearing_rad - bearing + math.pi) % (2 * math.pi) - math.pi
                distance = math.hypot(dx, dy)
                errors.append((distance, sighting.distance_m - distance, bearing_error))
            timed("encode", lambda: writer.write(image))  # noqa: B023
            timed("render", lambda: renderer.render(seen.image, *CELLS))  # noqa: B023
            if HAVE_RICH_PIXELS:
                timed("rich-pixels", lambda: rich_pixels(seen.image))  # noqa: B023
        writer.release()
    medians = {
        name: (
            statistics.median(wall for wall, _ in values) * 1e3,
            statistics.median(cpu for _, cpu in values) * 1e3,
        )
        for name, values in times.items()
        if values
    }
    return medians, found / frames, errors


def corners(fast: FastCorners, image):
    grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    return grey, fast.process(image, grey, 0.0).image


def rich_pixels(image) -> None:
    from PIL import Image
    from rich_pixels import Pixels

    rgb = cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
    Pixels.from_image(Image.fromarray(rgb), resize=(CELLS[0], CELLS[1] * 2))


def full_pipeline(seconds: float, recording: bool = True,
                  fps_cap: float = 10.0) -> tuple[float, float, int, int]:  # fmt: skip
    """Frames per second, share of one core, frames written and dropped."""
    camera, detector = building()
    # Every marker of the building in turn, over and over.
    walk = itertools.cycle(poses(camera, 10 * len(camera.world.markers)))
    pipeline = Pipeline([FastCorners(), detector])
    pipeline.toggle("fast")
    pipeline.toggle("markers")
    with tempfile.TemporaryDirectory() as scratch:
        recorder = VideoRecorder(Path(scratch) / "camera", SIZE) if recording else None

        class Recorded:
            name = "synthetic camera"

            def open(self, width, height):
                return width, height

            def read(self):
                frame = Frame(camera.render(next(walk), *SIZE), time.monotonic())
                if recorder is not None:
                    recorder.submit(RecordedFrame(frame, (0.0, 0.0, 0.0)))
                return frame

            def close(self):
                pass

        shown = []
        feed = CameraFeed(Recorded(), SIZE, pipeline, HalfBlockRenderer(), shown.append, fps_cap)
        feed.set_cells(*CELLS)
        cpu, wall = time.process_time(), time.perf_counter()
        feed.start()
        time.sleep(seconds)
        feed.stop()
        if recorder is not None:
            recorder.close()
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        if recorder is None:
            return len(shown) / wall, cpu / wall, 0, 0
        return len(shown) / wall, cpu / wall, recorder.written, recorder.dropped


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="full-pipeline run")
    parser.add_argument("--uncapped-seconds", type=float, default=20.0,
                        help="the run without a frame-rate cap")  # fmt: skip
    parser.add_argument("--busy", type=int, default=0, metavar="N",
                        help="busy loops to run beside the benchmark")  # fmt: skip
    args = parser.parse_args()
    busy = [subprocess.Popen([sys.executable, "-c", "while 1: pass"]) for _ in range(args.busy)]
    try:
        report(args)
    finally:
        for loop in busy:
            loop.kill()
            loop.wait()


def report(args: argparse.Namespace) -> None:
    print(f"{args.busy} busy loops beside it; {cv2.getNumThreads()} OpenCV threads")
    stages, found, errors = stage_times(60)
    print(f"camera pipeline at {SIZE[0]}x{SIZE[1]}, terminal view {CELLS[0]}x{CELLS[1]} cells")
    for name, (wall, cpu) in stages.items():
        print(f"  {name:<12}{wall:8.2f} ms/frame, CPU {cpu:6.2f} ms (medians of 60)")
    print(f"  markers found: {found:.2f} a frame")
    for low, high in ((0.0, 2.0), (2.0, 3.0), (3.0, 9.0)):
        band = [(d, b) for distance, d, b in errors if low <= distance < high]
        if band:
            worst_d = max(abs(d) for d, _ in band) * 100
            worst_b = max(abs(math.degrees(b)) for _, b in band)
            print(f"    {low:.0f}-{high:.0f} m: {len(band):3} sightings, worst distance error "
                  f"{worst_d:.1f} cm, bearing {worst_b:.2f} deg")  # fmt: skip
    if HAVE_RICH_PIXELS:
        ratio = stages["rich-pixels"][0] / stages["render"][0]
        print(f"  half-block renderer {ratio:.1f}x faster than rich-pixels")
    else:
        print("  rich-pixels not installed (pip install '.[bench]'): no comparison")
    ratio = stages["(stock)"][1] / stages["markers"][1]
    print(f"  marker detection {ratio:.1f}x less CPU than OpenCV's stock detector")
    fps, share, written, dropped = full_pipeline(args.seconds)
    print(f"full pipeline for {args.seconds:.0f} s: {fps:.1f} fps, {share:.0%} of one core, "
          f"{written} frames recorded, {dropped} dropped")  # fmt: skip
    seconds = args.uncapped_seconds
    fps, share, _, _ = full_pipeline(seconds, recording=False, fps_cap=1000.0)
    print(f"as the console runs it, uncapped, for {seconds:.0f} s: {fps:.1f} fps, "
          f"{share:.0%} of one core")  # fmt: skip


if __name__ == "__main__":
    main()
