"""The camera view outlines the markers the detector finds, with their ids, once `o`
turns the drawing on; the ids show on the top line either way (issue 14)."""

from __future__ import annotations

import math

from rich.color import Color

from giraff_console.robot.odometry import Pose
from giraff_console.sim.drive import TruePose
from giraff_console.tui.top_bar import TopBar
from tests.tui.conftest import EXAMPLE, Rig


def green_cells(lines) -> int:
    """Half-block cells with a half in the outline's green (camera/markers.py)."""
    count = 0
    for line in lines:
        for segment in line:
            style = segment.style
            halves = (style.color, style.bgcolor) if style is not None else ()
            count += any(isinstance(c, Color) and _green(c) for c in halves)
    return count


def _green(colour: Color) -> bool:
    # Blended with what is beside it at this resolution, but clearly green.
    red, green, blue = colour.get_truecolor()
    return green > red + 50 and green > blue + 50


async def test_the_camera_outlines_the_markers_it_finds_once_o_is_pressed():
    rig = Rig(camera=True, floorplan=EXAMPLE)
    assert rig.camera is not None
    # A metre and a half in front of marker 16, on the dock's north wall.
    near = Pose(2.8, 8.5, math.pi / 2)
    rig.board.place(TruePose(near.x, near.y, near.heading))
    rig.control.place(near)
    async with rig.app.run_test(size=(120, 40)) as pilot:
        await rig.run(pilot, 0.1)
        plain = rig.camera.picture()
        assert plain is not None and plain.markers == (16,)  # found, drawn or not
        await pilot.press("o")
        outlined = rig.camera.picture()
        assert outlined is not None and outlined.markers == (16,)
        assert green_cells(outlined.lines) >= green_cells(plain.lines) + 4, (
            green_cells(outlined.lines),
            green_cells(plain.lines),
        )
        await rig.show_camera(pilot)
        assert "markers 16" in str(rig.app.query_one(TopBar).render())
