"""What the camera leaves undone (issue 26): a hidden picture is neither processed for the
screen nor drawn, an unchanged picture is not drawn again, and the marker detector runs
at the rate the localisation needs rather than the camera's."""

from __future__ import annotations

import math

import numpy as np
import pytest

from giraff_console.camera.feed import CameraFeed
from giraff_console.camera.halfblock import HalfBlockRenderer
from giraff_console.camera.markers import MarkerDetector
from giraff_console.camera.processors import FastCorners, Pipeline, Processed
from giraff_console.camera.source import Frame
from giraff_console.sim.pose_view import PoseView
from giraff_console.sim.surroundings import Surroundings
from tests.camera.test_markers import CAMERA, FAMILY, POSE, SIZE, frame, synthetic
from tests.camera.test_processing import drawn_image


class Counted:
    """A processor that counts what it is asked: drawn frames and frames only looked at."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.drawn: list[float] = []
        self.found: list[float] = []

    def process(self, image: np.ndarray, grey: np.ndarray, captured_at: float) -> Processed:
        self.drawn.append(captured_at)
        return Processed(image.copy(), {self.name: captured_at})

    def find(self, grey: np.ndarray, captured_at: float) -> dict[str, object]:
        self.found.append(captured_at)
        return {self.name: captured_at}


class Stills:
    """A camera source that gives the same image until told to change it, stamped by a
    clock the test moves on a tenth of a second a frame."""

    name = "stills"

    def __init__(self, image: np.ndarray) -> None:
        self.image = image
        self.now = 0.0

    def open(self, width: int, height: int) -> tuple[int, int]:
        return width, height

    def read(self) -> Frame | None:
        self.now += 0.1
        return Frame(self.image, self.now)

    def close(self) -> None:
        pass


class CountedRenderer(HalfBlockRenderer):
    def __init__(self) -> None:
        super().__init__()
        self.renders = 0

    def render(self, image, columns, rows):
        self.renders += 1
        return super().render(image, columns, rows)


def feed_of(source, *processors) -> tuple[CameraFeed, CountedRenderer]:
    renderer = CountedRenderer()
    pipeline = Pipeline(list(processors))
    return CameraFeed(source, (260, 200), pipeline, renderer, lambda picture: None), renderer


def test_a_hidden_feed_draws_no_picture_and_runs_no_overlay_but_feeds_its_listeners():
    overlay, needed = Counted("fast"), Counted("markers")
    feed, renderer = feed_of(Stills(drawn_image()), overlay, needed)
    feed.pipeline.toggle("fast")
    feed.pipeline.require("markers")
    heard = []
    feed.listeners.append(lambda captured, data: heard.append(data))
    feed.shown = False
    for _ in range(5):
        feed.source.image = drawn_image() + 1  # a new picture every frame
        assert feed.picture() is None
    assert renderer.renders == 0 and feed.renders == 0
    assert overlay.drawn == overlay.found == []  # FAST is for the operator's eye alone
    assert needed.drawn == [] and len(needed.found) == 5  # found, not drawn
    assert [data["markers"] for data in heard] == pytest.approx([0.1, 0.2, 0.3, 0.4, 0.5])


def test_shown_again_the_next_frame_is_drawn_with_its_overlay():
    overlay = Counted("fast")
    feed, renderer = feed_of(Stills(drawn_image()), overlay)
    feed.pipeline.toggle("fast")
    feed.shown = False
    assert feed.picture() is None
    feed.shown = True
    assert feed.picture() is not None
    assert renderer.renders == 1 and len(overlay.drawn) == 1


def test_the_same_picture_again_is_not_processed_or_drawn_again(monkeypatch):
    ticks = iter(np.arange(1000) * 0.1)  # the feed's own clock, for its rate: 10 fps
    monkeypatch.setattr("giraff_console.camera.feed.time.monotonic", lambda: next(ticks))
    overlay, needed = Counted("fast"), Counted("markers")
    source = Stills(drawn_image())
    feed, renderer = feed_of(source, overlay, needed)
    feed.pipeline.toggle("fast")
    feed.pipeline.require("markers")
    heard = []
    feed.listeners.append(lambda captured, data: heard.append(data))
    pictures = [feed.picture() for _ in range(30)]
    first = pictures[0]
    assert first is not None and renderer.renders == 1 and len(overlay.drawn) == 1
    # While the rate builds up, the top line says so, with the same lines: the screen
    # has nothing new to draw. Once it holds, nothing at all is handed on.
    later = [picture for picture in pictures[1:] if picture is not None]
    assert all(picture.lines is first.lines for picture in later)
    assert [picture.fps for picture in later] == list(range(2, 11))
    assert pictures[-15:] == [None] * 15
    # The localisation still hears of every frame: the detector is not the screen's.
    assert len(needed.found) == len(heard) == 30
    source.image = drawn_image() + 1
    assert feed.picture() is not None and renderer.renders == 2


def test_the_same_picture_is_drawn_again_when_the_overlays_or_the_pane_change():
    feed, renderer = feed_of(Stills(drawn_image()), FastCorners())
    assert feed.picture() is not None
    feed.pipeline.toggle("fast")  # the operator asks for FAST on a still picture
    picture = feed.picture()
    assert picture is not None and picture.keypoints and renderer.renders == 2
    feed.set_cells(40, 10)
    assert feed.picture() is not None and renderer.renders == 3


def test_a_required_processor_runs_at_its_rate_on_a_faster_camera():
    needed = Counted("markers")
    pipeline = Pipeline([needed])
    pipeline.require("markers", 10.0)
    image = drawn_image()
    for n in range(90):  # three seconds at 30 frames a second
        pipeline.run(image, n / 30, shown=False)
    assert len(needed.found) == 30
    assert np.diff(needed.found) == pytest.approx(np.full(29, 0.1), abs=0.02)


def test_a_camera_at_just_the_required_rate_loses_no_frame_to_its_jitter():
    needed = Counted("markers")
    pipeline = Pipeline([needed])
    pipeline.require("markers", 10.0)
    times = [0.1 * n + (0.004 if n % 2 else -0.004) for n in range(50)]
    for captured_at in times:
        pipeline.run(drawn_image(), captured_at, shown=False)
    assert needed.found == times


def test_a_required_processor_shown_runs_on_every_frame_and_an_unknown_time_always():
    needed = Counted("markers")
    pipeline = Pipeline([needed])
    pipeline.require("markers", 10.0)
    pipeline.toggle("markers")
    for n in range(6):
        pipeline.run(drawn_image(), n / 30)
    assert len(needed.drawn) == 6 and needed.found == []
    pipeline.run(drawn_image(), math.nan, shown=False)
    pipeline.run(drawn_image(), math.nan, shown=False)
    assert len(needed.found) == 2
    with pytest.raises(ValueError):
        pipeline.require("markers", 0.0)


def test_a_frame_nobody_is_to_see_is_not_even_turned_grey(monkeypatch):
    needed = Counted("markers")
    pipeline = Pipeline([FastCorners(), needed])
    pipeline.toggle("fast")
    pipeline.require("markers", 1.0)
    pipeline.run(drawn_image(), 0.0, shown=False)
    monkeypatch.setattr("cv2.cvtColor", lambda *args: pytest.fail("turned grey"))
    image = drawn_image()
    assert pipeline.run(image, 0.3, shown=False).image is image


def test_the_detector_finds_the_same_frame_again_without_searching_it():
    detector = MarkerDetector(FAMILY, SIZE, synthetic)
    grey = frame()[..., 1].copy()
    [first] = detector.detect(grey, 1.0)
    searches = []
    real = detector._find
    detector._find = lambda image: searches.append(1) or real(image)  # type: ignore[method-assign]
    [again] = detector.detect(grey.copy(), 2.0)
    assert searches == [] and detector.repeats == 1
    assert again.frame_time == 2.0 and first.frame_time == 1.0
    assert (again.id, again.distance_m, again.bearing_rad) == (
        first.id, first.distance_m, first.bearing_rad,
    )  # fmt: skip
    grey[:10] = 0  # a new frame, however little changed: searched afresh
    assert len(detector.detect(grey, 3.0)) == 1 and searches == [1]


def test_the_detector_is_not_fooled_by_a_frame_drawn_into_the_last_one_s_array():
    detector = MarkerDetector(FAMILY, SIZE, synthetic)
    grey = frame()[..., 1].copy()
    assert len(detector.detect(grey, 1.0)) == 1
    grey[:] = 128  # the caller reuses its buffer: nothing to find now
    assert detector.detect(grey, 2.0) == [] and detector.repeats == 0


def test_the_simulated_view_is_drawn_again_only_when_something_in_it_changed():
    surroundings = Surroundings()
    camera = type(CAMERA)(CAMERA.world, surroundings=surroundings)
    pose = [POSE]
    view = PoseView(camera, lambda: pose[0])
    first = view(320, 240)
    assert view(320, 240) is first and view.drawings == 1
    assert not first.flags.writeable  # shared by every frame that shows it
    assert np.array_equal(first, camera.render(POSE, 320, 240))
    pose[0] = type(POSE)(POSE.x + 0.01, POSE.y, POSE.heading)
    assert view(320, 240) is not first and view.drawings == 2
    assert view(400, 300).shape == (300, 400, 3) and view.drawings == 3
    surroundings.block(4.0, 0.1)  # a box put down in front of the marker
    assert view(400, 300) is not None and view.drawings == 4
