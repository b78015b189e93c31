"""The operator console (§3.7, Figure 3.4, adapted to a terminal).

A thin front end: keys and typed commands go to the control loop, snapshots and
transcript lines come back as messages. The app never talks to the board itself.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, Vertical
from textual.message import Message
from textual.widgets import Footer

from giraff_console.camera.feed import CameraFeed
from giraff_console.camera.source import RESOLUTIONS as CAMERA_RESOLUTIONS
from giraff_console.link import Exchange
from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.missions.navigation import NavigationState, Navigator
from giraff_console.missions.route_book import RouteBook
from giraff_console.missions.sessions import Sessions
from giraff_console.protocol import Command, CommandError, GiraffError, parse_command, parse_number
from giraff_console.robot.command_guard import check_command
from giraff_console.robot.control_loop import BoardJob, ControlLoop
from giraff_console.robot.deadman import Intent
from giraff_console.robot.loop_events import LoopEvent, Note
from giraff_console.robot.odometry import Pose
from giraff_console.robot.safety import stop_robot
from giraff_console.robot.telemetry import Telemetry
from giraff_console.sim_site import SimulatedSite
from giraff_console.tui.camera_view import CameraView
from giraff_console.tui.command_line import CommandLine
from giraff_console.tui.help_screen import HelpScreen
from giraff_console.tui.key_guard import KeyGuard
from giraff_console.tui.main_view import MainView
from giraff_console.tui.map_scene import MapScene, located, plan_scene
from giraff_console.tui.map_view import MapView
from giraff_console.tui.messages import (
    CameraPictureUpdated,
    ExchangeSeen,
    NavigationChanged,
    StatusNote,
    TelemetryUpdated,
)
from giraff_console.tui.navigation_commands import NAVIGATION_COMMANDS, NavigationCommands
from giraff_console.tui.room_palette import RoomCommands
from giraff_console.tui.session_commands import ROUTE_COMMANDS, SESSION_COMMANDS, SessionCommands
from giraff_console.tui.stalk_commands import STALK_COMMANDS, StalkCommands
from giraff_console.tui.status_log import StatusLog
from giraff_console.tui.top_bar import TopBar
from giraff_console.tui.transcript import Transcript

# Keys 1-5 of the thesis (B.7 SetResolution).
RESOLUTIONS = dict(enumerate(CAMERA_RESOLUTIONS, start=1))
# T tilts the head up: the thesis's SetTilt(1), radians from home (B.7).
TILT_UP = 1.0

CONSOLE_COMMANDS = [
    ("help", "show this screen"),
    ("stop", "let go of the keys and stop the robot now"),
    ("speed X", "set the driving speed in m/s, within the configured cap"),
    ("quit", "stop the robot and leave"),
    ("set NAME VALUE", "send a controller command, e.g. set v 0.3 (checked against the limits)"),
    ("get NAME", "read a parameter, e.g. get bulk_data"),
    ("home", "any other bare controller command"),
    ("stalk up|down|N", "raise or lower the head's stalk a step, or set it 0-1000 (g, v)"),
    ("fast, canny, markers", "switch a camera processor on or off (markers: outlines, ids)"),
    ("record, record stop", "record a session into recordings/ (also r)"),
    ("play [DIR], play stop", "play the newest session, or DIR, back; stop it (also p)"),
    ("pause, resume, seek S, rate X", "control a playback: seconds in, speed 0.25 to 16"),
    ("teach NAME, mark PLACE, done", "teach a route by driving it; name places on the way"),
    ("routes", "list the taught routes and the patrols"),
    ("replay-route NAME", "drive a taught route again, open-loop (keys or Space stop it)"),
    ("follow-route NAME", "drive a taught route's path closed-loop, like go (from its start)"),
    ("patrol NAME, patrol pause|resume|stop", "run routes/NAME.patrol.yaml; hold or end it"),
    ("undock", "back out of the dock and turn round (also u, twice)"),
    ("go ROOM", "drive to ROOM: the route is planned, shown on the map and driven"),
    ("pause, resume", "hold the robot where it is on its way, and go on (also playbacks)"),
    ("close DOOR, open DOOR", "shut or open a door (in the simulator too); routes go round"),
    ("block X Y, unblock X Y", "simulator: put a box in the way at X, Y metres, or take it"),
]
# The layouts of the centre that M steps through: camera and map, the map, the camera.
LAYOUTS = ("both", "map", "camera")


class GiraffConsole(NavigationCommands, SessionCommands, StalkCommands, KeyGuard):
    """The operator's screen; `control` runs the robot."""

    CSS_PATH = "app.tcss"
    TITLE = "giraff-console"
    COMMANDS = KeyGuard.COMMANDS | {RoomCommands}
    # Nothing takes the focus by itself: the keys belong to driving until Enter is pressed.
    AUTO_FOCUS = None
    BINDINGS = [
        Binding("escape", "quit", "Quit", id="quit",
                tooltip="stop the robot and leave (also q); asks first while anything runs"),
        Binding("q", "quit", "Quit", show=False, id="quit-q"),
        Binding("up", "drive('FORWARD')", "Drive", key_display="↑↓←→", id="forward",
                tooltip="hold to drive forward"),
        Binding("down", "drive('BACKWARD')", "Back", show=False, id="backward",
                tooltip="hold to drive backward"),
        Binding("left", "drive('LEFT')", "Left", show=False, id="left",
                tooltip="hold to turn left in place"),
        Binding("right", "drive('RIGHT')", "Right", show=False, id="right",
                tooltip="hold to turn right in place"),
        Binding("home,left_square_bracket", "drive('FORWARD_LEFT')", "Fwd-left", show=False,
                id="forward-left", tooltip="hold to drive forward curving left (Home or [)"),
        Binding("pageup,right_square_bracket", "drive('FORWARD_RIGHT')", "Fwd-right", show=False,
                id="forward-right", tooltip="hold to drive forward curving right (PgUp or ])"),
        Binding("space", "halt", "Stop", id="stop", tooltip="stop now"),
        Binding("plus,equals_sign", "speed(1)", "Faster", show=False, id="faster",
                tooltip="drive 0.05 m/s faster, up to the cap"),
        Binding("minus", "speed(-1)", "Slower", show=False, id="slower",
                tooltip="drive 0.05 m/s slower"),
        *[Binding(str(n), f"resolution({n})", f"{w}x{h}", show=False, id=f"resolution-{n}",
                  tooltip=f"camera resolution {w}x{h}") for n, (w, h) in RESOLUTIONS.items()],
        Binding("f", "processor('fast')", "FAST", show=False, id="fast",
                tooltip="FAST corners on the camera image, on or off"),
        Binding("e", "processor('canny')", "Edges", show=False, id="canny",
                tooltip="Canny edges on the camera image, on or off"),
        Binding("o", "processor('markers')", "Markers", show=False, id="markers",
                tooltip="outline the markers the camera finds, with their ids, on or off"),
        Binding("enter", "command_line", "Command", id="command",
                tooltip="type a controller or console command"),
        Binding("a", "toggle_poll", "Poll", show=False, id="poll",
                tooltip="toggle the automatic odometry poll"),
        Binding("b", "bulk", "Bulk", show=False, id="bulk", tooltip="request bulk_data"),
        Binding("h", "home_head", "Home", show=False, id="home",
                tooltip="home the head (then y to do it)"),
        Binding("p", "playback", "Play", show=False, id="play",
                tooltip="play the newest session back, or return to live"),
        Binding("r", "record", "Rec", show=False, id="record",
                tooltip="start or stop recording a session"),
        Binding("k", "pause_playback", "Pause", show=False, id="pause",
                tooltip="pause or resume the playback"),
        Binding("full_stop", "step_playback", "Step", show=False, id="step",
                tooltip="pause the playback and step to the next line"),
        Binding("j", "seek(-10)", "Back 10 s", show=False, id="seek-back",
                tooltip="playback 10 s back"),
        Binding("l", "seek(10)", "On 10 s", show=False, id="seek-on",
                tooltip="playback 10 s on"),
        Binding("less_than_sign", "rate(0.5)", "Slower", show=False, id="rate-down",
                tooltip="play back at half the speed, down to 0.25x"),
        Binding("greater_than_sign", "rate(2)", "Faster", show=False, id="rate-up",
                tooltip="play back at twice the speed, up to 16x"),
        Binding("t", "tilt", "Tilt", show=False, id="tilt",
                tooltip="tilt the head up (then y to do it)"),
        Binding("u", "undock", "Undock", show=False, id="undock",
                tooltip="back out of the dock and turn around (then y to do it)"),
        Binding("g", "stalk(1)", "Stalk up", show=False, id="stalk-up",
                tooltip="raise the head one step on its stalk (later boards)"),
        Binding("v", "stalk(-1)", "Stalk down", show=False, id="stalk-down",
                tooltip="lower the head one step on its stalk (later boards)"),
        Binding("m", "layout", "Map", id="map", tooltip="camera and map, the map, the camera"),
        Binding("z", "zoom(1.5)", "Zoom in", show=False, id="zoom-in",
                tooltip="zoom the map in (also the mouse wheel)"),
        Binding("x", "zoom(0.6667)", "Zoom out", show=False, id="zoom-out",
                tooltip="zoom the map out"),
        Binding("shift+left", "pan(-4, 0)", "Pan", show=False, id="pan-left",
                tooltip="move the map view left (Shift+arrows; or drag it)"),
        Binding("shift+right", "pan(4, 0)", "Pan", show=False, id="pan-right",
                tooltip="move the map view right"),
        Binding("shift+up", "pan(0, -2)", "Pan", show=False, id="pan-up",
                tooltip="move the map view up"),
        Binding("shift+down", "pan(0, 2)", "Pan", show=False, id="pan-down",
                tooltip="move the map view down"),
        Binding("c", "follow", "Follow", show=False, id="follow",
                tooltip="keep the robot in view on the map again"),
        Binding("question_mark", "help", "Help", id="help", tooltip="this screen"),
    ]  # fmt: skip
    # Priority: the app takes each key as it arrives, in the order typed. Otherwise a key
    # goes round through the screen and comes back late, behind the keys typed after it:
    # under load Enter opened the command line after the next keys had run their
    # bindings (issue 12). check_action hands the keys on while a screen is on top.
    BINDINGS = [replace(b, priority=True) for b in BINDINGS if isinstance(b, Binding)]

    def __init__(
        self,
        control: ControlLoop,
        *,
        simulator: bool,
        camera: CameraFeed | None = None,
        sessions: Sessions | None = None,
        routes: RouteBook | None = None,
        play: Path | None = None,
        navigator: Navigator | None = None,
        site: SimulatedSite | None = None,
        drives: DriveSetup | None = None,
        stepped: float | None = None,
        undock_distance: float = 0.3,
        battery_low: float = 25.0,
        run_loop: bool = True,
        timestamp: Callable[[], str] = lambda: time.strftime("%H:%M:%S"),
        cursor_blink: bool = True,
        crashed: Callable[[BaseException], None] = lambda error: None,
    ) -> None:
        """`drives` builds the missions `go` drives; `run_loop` False leaves ticking the
        loop to the caller (tests on a virtual clock); `battery_low` is the percent below
        which the top line shows the battery LOW."""
        super().__init__()
        self.control = control
        self.camera = camera
        self.sessions = sessions
        self.routes = routes
        self.play_at_start = play
        self.navigator = navigator
        self.site = site
        if drives is None:
            # The default limits, and the simulated building's range finder if any.
            sense = site.range_finder.readings if site is not None else None
            drives = DriveSetup.on_loop(control, navigator, sense=sense)
        # One navigator: the map shows the state of the one `go` plans with.
        assert drives.navigator is navigator, "drives must plan with the console's navigator"
        self.drives = drives
        self.stepped = stepped
        self._shown_state: NavigationState | None = None
        start = navigator.start_pose if navigator is not None else None
        self.pose = start or Pose()
        # Lines for the status log once it is on screen (how the console was set up).
        self.notes_at_start: list[str] = []
        self._scene: MapScene | None = None
        self._layout = 0
        self.simulator = simulator
        self.undock_distance = undock_distance
        self.battery_low = battery_low
        # The latest snapshot: the stalk keys step from the height it reports.
        self.telemetry: Telemetry | None = None
        self.run_loop = run_loop
        self.timestamp = timestamp
        self.cursor_blink = cursor_blink
        # Told first of an exception nothing handled (robot/last_stop.py).
        self.crashed = crashed
        self._frames: list[float] = []
        # What the last snapshot said of the robot: quitting asks first while it moves.
        self._moving = False
        # Made here, not in compose: which keys work depends on it from the start.
        self.command_line = CommandLine(self._navigation_words(), id="command-line")
        self.command_line.cursor_blink = cursor_blink
        self.command_line.display = False

    def compose(self) -> ComposeResult:
        yield TopBar(self.simulator, battery_low=self.battery_low, id="top")
        with Horizontal(id="body"):
            yield StatusLog(id="status")
            with Vertical(id="centre"):
                yield CameraView(id="camera")
                truecolor = os.environ.get("COLORTERM") in ("truecolor", "24bit")
                yield MapView(truecolor, id="map")
                yield MainView(id="main")
            yield Transcript(id="transcript")
        yield self.command_line
        yield Footer()

    def on_mount(self) -> None:
        self.top_bar = self.query_one(TopBar)
        self.main_view = self.query_one(MainView)
        self.status_log = self.query_one(StatusLog)
        self.transcript = self.query_one(Transcript)
        self.camera_view = self.query_one(CameraView)
        self.map_view = self.query_one(MapView)
        navigator = self.navigator
        if navigator is not None and navigator.walls is not None:
            self._scene = plan_scene(navigator.plan, navigator.walls)
            self._show_map()
        else:
            self.map_view.display = False  # nothing to draw: the camera has the room
        self.control.subscribe(self._from_loop, vital=True)
        for service in (self.sessions, self.routes):
            if service is not None:
                service.report = lambda text: self._post(StatusNote(text))
        if self.simulator:
            self.note("SIMULATOR: no robot is connected; the built-in simulated board answers")
        for text in self.notes_at_start:
            self.note(text)
        if self.camera is not None:
            camera = self.camera
            camera.publish = lambda picture: self._post(CameraPictureUpdated(picture))
            self.camera_view.on_size = camera.set_cells
            self.call_after_refresh(lambda: camera.set_cells(*self.camera_view.size))
            self.note(f"camera: {camera.note}")
            if self.run_loop:
                camera.start()
        if self.run_loop:
            self.control.start(stepped=self.stepped)
        if self.play_at_start is not None:
            self._play(self.play_at_start)

    def _handle_exception(self, error: Exception) -> None:
        # An exception in a handler or a worker: the robot is stopped before anything
        # else, then Textual reports it and closes the console (design.md).
        self.crashed(error)
        super()._handle_exception(error)

    def on_unmount(self) -> None:
        self.control.stop()
        self.control.unsubscribe(self._from_loop)
        if self.sessions is not None:
            self.sessions.stop_recording()
        if self.camera is not None:
            self.camera.stop()

    def on_camera_picture_updated(self, message: CameraPictureUpdated) -> None:
        picture = message.picture
        text = f"cam {picture.size[0]}x{picture.size[1]} {picture.fps:.0f} fps"
        if picture.keypoints is not None:
            text += f" · FAST {picture.keypoints}"
        if picture.markers:
            text += f" · markers {' '.join(map(str, sorted(picture.markers)))}"
        self.top_bar.show_camera(text)
        self.camera_view.show(picture)

    # -- from the control loop ----------------------------------------------------------

    def on_telemetry_updated(self, message: TelemetryUpdated) -> None:
        now = self.control.clock.now()
        self._frames = [t for t in self._frames if now - t < 1.0] + [now]
        self.top_bar.ui_fps = float(len(self._frames))
        self.top_bar.recording = self.sessions is not None and self.sessions.recording
        telemetry = self.telemetry = message.telemetry
        self._moving = telemetry.intent is not None or (
            telemetry.state is not None and telemetry.state.moving
        )
        self.top_bar.show(message.telemetry)
        self.main_view.show(message.telemetry)
        # Every snapshot: the map view draws again only if what it shows has changed.
        self.pose = message.telemetry.pose
        self._show_map(self.navigator.state if self.navigator is not None else None)

    def on_navigation_changed(self, message: NavigationChanged) -> None:
        self._show_map(message.state)

    def _show_map(self, state: NavigationState | None = None) -> None:
        """Draw the robot where it is, with the route and the doors as they are now."""
        if self._scene is None or self.navigator is None:
            return
        if state is not None and state is not self._shown_state:
            self._shown_state = state
            closed = state.closed
            doors = tuple(replace(door, open=door.id not in closed) for door in self._scene.doors)
            path = tuple(state.planned.path) if state.planned is not None else ()
            self._scene = replace(self._scene, doors=doors, path=path, obstacles=state.obstacles)
        estimate = self.telemetry.estimate if self.telemetry is not None else None
        self._scene = located(self._scene, self.pose, estimate)
        self.map_view.show(self._scene)

    def on_exchange_seen(self, message: ExchangeSeen) -> None:
        self.transcript.add(message.exchange)

    def on_status_note(self, message: StatusNote) -> None:
        self.note(message.text)

    def note(self, text: str) -> None:
        self.status_log.note(f"{self.timestamp()} {text}")

    def _from_loop(self, event: LoopEvent) -> None:
        """Whatever the loop says, as a message from its thread to the screen."""
        if isinstance(event, Telemetry):
            self.post_message(TelemetryUpdated(event))
        elif isinstance(event, Note):
            self.post_message(StatusNote(event.text))
        elif isinstance(event, Exchange):
            self.post_message(ExchangeSeen(event))

    def _post(self, message: Message) -> None:
        """`post_message` for the callbacks the services make, which return nothing."""
        self.post_message(message)

    # -- keys ---------------------------------------------------------------------------

    def action_drive(self, intent: str) -> None:
        if self.command_line.has_focus:
            return
        if self.control.playback is not None:
            self.note("playing back: the driving keys are off; p returns to live")
            return
        self.control.press(Intent[intent])

    def action_halt(self) -> None:
        """Stop now: let go of the keys, and stop any move, typed or undocking, as well."""
        self.control.halt()
        self.control.stop_mission("stopped by the operator")
        self.control.submit(stop_robot, stop=True)
        self.note("stop")

    def action_speed(self, step: int) -> None:
        speed = self.control.teleop.set_speed(round(self.control.teleop.speed + 0.05 * step, 2))
        self.note(f"driving speed {speed:.2f} m/s")

    def action_resolution(self, key: int) -> None:
        width, height = RESOLUTIONS[key]
        if self.camera is None:
            self.note("no camera")
            return
        self.camera.set_resolution(width, height)
        self.note(f"camera resolution {width}x{height} requested")

    def action_processor(self, name: str) -> None:
        if self.camera is None:
            self.note("no camera")
            return
        if name not in self.camera.pipeline.processors:
            self.note(f"no {name}: the floor plan has no landmarks")
            return
        on = self.camera.pipeline.toggle(name)
        self.note(f"{name} {'on' if on else 'off'}")

    def action_command_line(self) -> None:
        self.open_command_line()

    def action_toggle_poll(self) -> None:
        self.control.autopoll = not self.control.autopoll
        self.note(f"automatic odometry poll {'on' if self.control.autopoll else 'off'}")

    def action_bulk(self) -> None:
        self._board_command(Command("get", "bulk_data"))

    # h, t and u move the robot's head or the robot without being held: one stray key
    # must not do it (issue 12), so each asks, and only y does it: the same key again
    # would be a held key's own auto-repeat.

    def action_home_head(self) -> None:
        def home() -> None:
            self._board_command(Command("command", "home"))

        if self._live():
            self.ask("home the head? y homes it, any other key does not", {"y"}, home)

    def action_tilt(self) -> None:
        def tilt() -> None:
            self._board_command(Command("set", "tilt_angle_from_home", TILT_UP))

        if self._live():
            self.ask("tilt the head up? y tilts it, any other key does not", {"y"}, tilt)

    def action_undock(self) -> None:
        if self._live() and self.routes is not None:
            self.ask(f"undock: back out {self.undock_distance:g} m and turn round? "
                     "y goes, any other key does not", {"y"}, self._undock)  # fmt: skip
        elif self.routes is None:
            self.note("undock is not available (no route book)")

    def _undock(self) -> None:
        """Back out and turn round, streamed by the console in bounded steps: never the
        board's own `set undock`, which a dead console cannot stop (issue 12)."""
        if self.routes is None:
            self.note("undock is not available (no route book)")
        elif self.routes.undock(self.undock_distance):
            self.note(f"undocking: backing out {self.undock_distance:g} m; Space stops")

    def _live(self) -> bool:
        """Whether commands may go to the robot: not while a session plays back."""
        if self.control.playback is not None:
            self.note("not sent: playing back, nothing goes to the robot (p returns to live)")
            return False
        return True

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        """No key of the app's works while the command line is open (the keys are the
        line's) or another screen (help, the command palette) is on top; the map's keys
        are off, and out of the footer, when there is no map."""
        if action == "halt":
            return True  # Space stops the robot whatever is on the screen
        if self.command_line.is_open or len(self.screen_stack) > 1:
            return False
        if action in ("layout", "zoom", "pan", "follow"):
            return self._scene is not None
        return True

    def action_layout(self) -> None:
        """Step the centre through camera and map, the map alone, the camera alone."""
        self._layout = (self._layout + 1) % len(LAYOUTS)
        centre = self.query_one("#centre")
        for layout in LAYOUTS:
            centre.set_class(layout == LAYOUTS[self._layout], f"-{layout}")

    def action_zoom(self, factor: float) -> None:
        self.map_view.zoom(factor)

    def action_pan(self, columns: int, rows: int) -> None:
        self.map_view.pan(columns, rows)

    def action_follow(self) -> None:
        self.map_view.centre_on_robot()

    def action_help(self) -> None:
        self.push_screen(HelpScreen(list(self.BINDINGS), CONSOLE_COMMANDS))

    async def action_quit(self) -> None:
        """Esc, q: ask first while anything runs, or right after the command line
        closed, where a second Esc meant for the line would otherwise quit."""
        self._quit(ask=self.quit_is_hasty())

    def _quit(self, ask: bool) -> None:
        busy = self._busy()
        if busy or ask:
            why = f"{busy}: " if busy else ""
            self.ask(f"quit? {why}y stops the robot and leaves, any other key stays", {"y"},
                     self._leave)  # fmt: skip
        else:
            self._leave()

    def _busy(self) -> str:
        """What would be cut short by quitting now, or ''."""
        mission = self.control.mission
        if mission is not None:
            return f"{mission.name} is running"
        if self.sessions is not None and self.sessions.recording:
            return "recording"
        if self._moving:
            return "the robot is moving"
        return ""

    def _leave(self) -> None:
        self.note("stopping the robot and leaving")
        # Stop first: the app takes a while to close its screens after exit().
        self.control.stop()
        self.exit()

    def _navigation_words(self) -> list[str]:
        """What the command line offers to complete: every room and door by name."""
        if self.navigator is None:
            return []
        rooms = [f"go {room_id}" for room_id in self.navigator.room_ids()]
        doors = self.navigator.door_ids()
        return rooms + [f"close {door}" for door in doors] + [f"open {door}" for door in doors]

    def _board_job(self, job: BoardJob) -> None:
        if self.control.playback is not None:
            self.note("not sent: playing back, nothing goes to the robot (p returns to live)")
            return

        def done(result: object) -> None:
            if isinstance(result, CommandError):
                self.post_message(StatusNote(f"refused: {result}"))
            elif isinstance(result, GiraffError):
                self.post_message(StatusNote(str(result)))

        self.control.submit(job, done)

    def _board_command(self, command: Command) -> None:
        """Check a command against the limits on the loop's thread, then send it.

        The check runs where the board's settings are known for sure: nothing can change
        them between the check and the command.
        """
        teleop = self.control.teleop

        def job(link):
            check_command(command, teleop.limits, teleop.board_settings)
            return link.send(command)

        self._board_job(job)

    # -- the command line ---------------------------------------------------------------

    def run_command(self, text: str) -> None:
        """A console command, or a controller command checked against the limits."""
        word, _, rest = text.partition(" ")
        if word == "help":
            self.action_help()
        elif word == "quit":
            self._quit(ask=False)  # typed in full: asks only while something runs
        elif word == "stop":
            self.action_halt()
        elif word == "undock":
            if self._live():
                self._undock()  # typed in full and sent with Enter: that is the confirmation
        elif word == "speed":
            try:
                wanted = float(parse_number(rest))
            except CommandError:
                self.note("refused: usage: speed 0.3")
                return
            speed = self.control.teleop.set_speed(wanted)
            self.note(f"driving speed {speed:.2f} m/s")
        elif word in ("fast", "canny", "markers"):
            self.action_processor(word)
        elif word in SESSION_COMMANDS:
            self._session_command(word, rest.strip())
        elif word in ROUTE_COMMANDS:
            self._route_command(word, rest.strip())
        elif word in NAVIGATION_COMMANDS:
            self._navigation_command(word, rest.strip())
        elif word in STALK_COMMANDS:
            self._stalk_command(rest.strip())
        else:
            try:
                command = parse_command(text)
            except CommandError as error:
                self.note(f"refused: {error}")
                return
            self._board_command(command)
