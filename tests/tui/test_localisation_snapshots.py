"""Snapshots of how well the robot knows where it is (issue 14): the pose's spread on the
top line, and the uncertainty ellipse and the markers on the map. Fixed sizes, a virtual
clock, no cursor blink, as test_snapshots.py."""

from __future__ import annotations

import math
from dataclasses import replace

from textual.app import App

from giraff_console.planning.landmarks import marker_poses
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.odometry import Pose
from giraff_console.robot.telemetry import LinkState, Telemetry
from giraff_console.tui.top_bar import TopBar
from tests.tui.conftest import EXAMPLE, Rig

POSE = Pose(12.4, 3.1, math.pi / 2)


def ellipse_estimate(pose: Pose, major: float, minor: float, angle_deg: float,
                     heading_deg: float, **kwargs) -> Estimate:  # fmt: skip
    """An estimate at `pose` whose position's 1-sigma ellipse is `major` x `minor` metres,
    its major axis `angle_deg` from +x, with the covariance that makes that ellipse."""
    angle = math.radians(angle_deg)
    c, s = math.cos(angle), math.sin(angle)
    xx = (major * c) ** 2 + (minor * s) ** 2
    yy = (major * s) ** 2 + (minor * c) ** 2
    xy = (major**2 - minor**2) * c * s
    heading = math.radians(heading_deg)
    covariance = ((xx, xy, 0.0), (xy, yy, 0.0), (0.0, 0.0, heading**2))
    return Estimate(pose, pose, covariance, major, heading, (major, minor, angle), **kwargs)


def test_top_line_shows_the_pose_with_its_uncertainty(snap_compare):
    """Found to 3 cm; not found yet; found but lost; a playback without an estimate."""

    def telemetry(estimate: Estimate | None) -> Telemetry:
        return Telemetry(LinkState.CONNECTED, None, POSE, None, 0.3, None, True, 20.0, 0.0,
                         estimate=estimate)  # fmt: skip

    estimates = {
        "found": ellipse_estimate(POSE, 0.03, 0.03, 0, 1.2, landmarks=True, found=True),
        "not-found": ellipse_estimate(POSE, 0.05, 0.05, 0, 3.0, landmarks=True),
        "lost": ellipse_estimate(POSE, 0.3, 0.1, 30, 2.0, landmarks=True, found=True),
        "playback": None,
    }

    class TopLines(App[None]):
        def compose(self):
            for name in estimates:
                yield TopBar(simulator=False, id=name)

        def on_mount(self) -> None:
            for name, estimate in estimates.items():
                self.query_one(f"#{name}", TopBar).show(telemetry(estimate))

    assert snap_compare(TopLines(), terminal_size=(90, 4))


def test_the_map_shows_the_uncertainty_ellipse_and_the_markers(snap_compare):
    """On the dock of the example care home, known to 0.3 m x 0.1 m at 30 degrees (two
    sigma drawn), three markers seen lately and one rejected, zoomed in on the map alone."""
    rig = Rig(floorplan=EXAMPLE)
    assert rig.navigator is not None
    rig.control.localisation.use_markers(marker_poses(rig.navigator.plan))
    found = rig.control.localisation.estimate

    def loose():
        estimate = found()
        shape = ellipse_estimate(estimate.pose, 0.3, 0.1, 30, 2.0)
        return replace(shape, odometry=estimate.odometry, landmarks=True, found=True,
                       seen=(16, 106, 110), rejected=(107,))  # fmt: skip

    rig.control.localisation.estimate = loose

    async def look(pilot):
        await rig.run(pilot, 0.2)
        await pilot.press("m", *"zzzzz", "c")  # the map alone, closer, on the robot
        await rig.run(pilot, 0.1)

    assert snap_compare(rig.app, terminal_size=(120, 40), run_before=look)
