"""Snapshots of the console at fixed sizes, on a virtual clock, with no cursor blink."""

from __future__ import annotations

from textual.app import App

from giraff_console.link import LinkDisconnected
from giraff_console.protocol.charger import ChargeStatus
from giraff_console.robot.battery import Battery
from giraff_console.robot.odometry import Pose
from giraff_console.robot.telemetry import LinkState, Telemetry
from giraff_console.tui.top_bar import TopBar
from tests.tui.conftest import EXAMPLE, Rig, record_demo_session


def test_start_screen_80x24(snap_compare, rig):
    async def start(pilot):
        await rig.run(pilot, 0.2)

    assert snap_compare(rig.app, terminal_size=(80, 24), run_before=start)


def test_start_screen_200x60(snap_compare, rig):
    async def start(pilot):
        await rig.run(pilot, 0.2)

    assert snap_compare(rig.app, terminal_size=(200, 60), run_before=start)


def test_help_screen(snap_compare, rig):
    async def help_screen(pilot):
        await rig.run(pilot, 0.1)
        await pilot.press("question_mark")

    assert snap_compare(rig.app, terminal_size=(100, 40), run_before=help_screen)


def test_after_driving(snap_compare, rig):
    async def drive(pilot):
        await rig.run(pilot, 0.1)
        await rig.hold(pilot, "pageup", 2.0)
        await rig.run(pilot, 2.0)

    assert snap_compare(rig.app, terminal_size=(100, 30), run_before=drive)


def test_link_lost(snap_compare, rig):
    async def lose_link(pilot):
        await rig.run(pilot, 0.1)

        def unplugged():
            raise LinkDisconnected("cannot open /dev/ttyS0: no such device")

        rig.control.connect = unplugged
        rig.link.port.close()  # the cable comes out
        await rig.run(pilot, 0.3)

    assert snap_compare(rig.app, terminal_size=(100, 30), run_before=lose_link)


def test_help_screen_80x24_scrolls(snap_compare, rig):
    async def help_screen(pilot):
        await rig.run(pilot, 0.1)
        await pilot.press("question_mark")

    assert snap_compare(rig.app, terminal_size=(80, 24), run_before=help_screen)


def test_synthetic_camera_at_a_fixed_pose(snap_compare, camera_rig):
    rig = camera_rig

    async def camera(pilot):
        await rig.run(pilot, 0.1)
        await rig.show_camera(pilot)

    assert snap_compare(rig.app, terminal_size=(120, 40), run_before=camera)


def test_playback_paused_with_its_video_pose_and_transcript(snap_compare, tmp_path):
    session = record_demo_session(tmp_path / "recordings")
    rig = Rig(camera=True, recordings=tmp_path / "recordings")

    async def play(pilot):
        await rig.run(pilot, 0.1)
        rig.app.run_command(f"play {session}")
        await rig.run(pilot, 1.6)
        await pilot.press("k")
        await rig.show_camera(pilot)
        await rig.run(pilot, 0.1)

    assert snap_compare(rig.app, terminal_size=(120, 40), run_before=play)


def test_the_map_shows_the_robot_on_its_way_to_the_day_room(snap_compare, care_home_rig):
    rig = care_home_rig

    async def go(pilot):
        await rig.run(pilot, 0.2)
        rig.app.run_command("go day-room")
        await rig.app.workers.wait_for_complete()
        await rig.run(pilot, 20.0)  # through the dock's door and along the corridor
        await pilot.press("m")  # the map alone

    assert snap_compare(rig.app, terminal_size=(120, 40), run_before=go)


def test_a_patrol_on_its_way_at_80x24(snap_compare, tmp_path):
    """At 80x24 the top line keeps the pose and the heading, and the main view the
    patrol, its stop and the leg's metres and ETA, the leg on a line of its own (issue
    26). The example night patrol, without its snapshots (a recording's folder would
    differ from run to run)."""
    rig = Rig(floorplan=EXAMPLE, recordings=tmp_path / "recordings")
    routes = tmp_path / "routes"
    routes.mkdir()
    night = (EXAMPLE.parents[1] / "routes" / "night.patrol.yaml").read_text()
    (routes / "night.patrol.yaml").write_text(f"{night}snapshots: false\n")

    async def patrol(pilot):
        await rig.run(pilot, 0.2)
        rig.app.run_command("patrol night")
        await rig.app.workers.wait_for_complete()
        await rig.run(pilot, 15.0)  # out of the dock, on the way to the nurse station

    assert snap_compare(rig.app, terminal_size=(80, 24), run_before=patrol)


def test_top_line_with_a_battery_and_the_stalk(snap_compare):
    """Only the top line, as a later board fills it: the rest of the screen is others'."""

    def telemetry(battery: Battery) -> Telemetry:
        return Telemetry(LinkState.CONNECTED, None, Pose(1.5, -0.25, 0.5), None, 0.3, None,
                         True, 20.0, 0.0, battery=battery, stalk=520)  # fmt: skip

    class TopLines(App[None]):
        def compose(self):
            yield TopBar(simulator=True, id="charging")
            yield TopBar(simulator=False, id="low")

        def on_mount(self) -> None:
            charging = Battery(ChargeStatus.FAST_CHARGING, 73.0, 25.1, 2.0, 30.0)
            self.query_one("#charging", TopBar).show(telemetry(charging))
            low = Battery(ChargeStatus.NOT_DOCKED, 18.0, 22.6, -1.0, 31.0)
            self.query_one("#low", TopBar).show(telemetry(low))

    assert snap_compare(TopLines(), terminal_size=(100, 3))
