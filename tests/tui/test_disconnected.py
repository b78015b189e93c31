"""A console attached to a daemon that goes (issue 26): DISCONNECTED on the top line with
nothing that looks live, keys that ask nothing, and the console as it was once a
daemon welcomes it again (service/reattach.py brings the events; this is the screen)."""

from __future__ import annotations

from giraff_console.service.daemon import Welcome
from giraff_console.service.events import Controls, Situation
from giraff_console.tui.messages import DaemonBack, DaemonLeft
from tests.tui.conftest import Rig

SIZE = (120, 30)


def top_line(rig: Rig) -> str:
    return str(rig.app.top_bar.render())


async def test_a_console_whose_daemon_went_says_so_and_its_keys_ask_nothing():
    rig = Rig()
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 1.0)
        assert "loop" in top_line(rig)
        rig.app.post_message(DaemonLeft("the daemon has gone"))
        await pilot.pause()
        line = top_line(rig)
        assert "DISCONNECTED" in line and "loop" not in line and "fps" not in line
        presses, start_x = rig.presses, rig.board.true_pose.x
        for _ in range(5):
            await pilot.press("up")
            await rig.run(pilot, 0.1)
        assert rig.presses == presses  # the keys asked nothing
        assert rig.board.true_pose.x == start_x  # and the robot did not move
        here = ("console a",)
        welcome = Welcome("console a", None, True, Controls("console a", here),
                          Situation(None, "console a", here, None, False, False), None)  # fmt: skip
        rig.app.post_message(DaemonBack(welcome))
        await rig.run(pilot, 0.5)
        assert "DISCONNECTED" not in top_line(rig) and "loop" in top_line(rig)
        await rig.hold(pilot, "up", 1.0)
        assert rig.presses > presses  # the keys drive again
