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

from textual import work
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, Vertical
from textual.message import Message

from giraff_console.camera.feed import CameraFeed, CameraPicture
from giraff_console.camera.halfblock import HalfBlockRenderer
from giraff_console.camera.shared_frame import SharedFrame, SharedFrameError, picture_of
from giraff_console.camera.source import RESOLUTIONS as CAMERA_RESOLUTIONS
from giraff_console.clock import Clock
from giraff_console.planning import room_names
from giraff_console.planning.floorplan import FloorPlan, FloorPlanError, load_floorplan
from giraff_console.planning.grid import OccupancyGrid
from giraff_console.planning.route_planner import walls_of
from giraff_console.service import commands as c
from giraff_console.service.building_map import picture_grid
from giraff_console.service.daemon import Welcome
from giraff_console.service.events import (
    Controls,
    MapDrawn,
    PlanChanged,
    Robot,
    RoomRenamed,
    RouteShown,
    ServiceEvent,
)
from giraff_console.service.reattach import Attached, Disconnected
from giraff_console.service.vocabulary import Exchange, Note, Pose, Telemetry
from giraff_console.tui.camera_view import CameraView
from giraff_console.tui.command_line import CommandLine
from giraff_console.tui.help_screen import HelpScreen
from giraff_console.tui.key_guard import KeyGuard
from giraff_console.tui.keys_footer import KeysFooter
from giraff_console.tui.main_view import MainView
from giraff_console.tui.map_scene import MapScene, located, plan_scene
from giraff_console.tui.map_view import MapView
from giraff_console.tui.messages import (
    Answer,
    CameraPictureUpdated,
    ControlsChanged,
    DaemonBack,
    DaemonLeft,
    ExchangeSeen,
    MapGrown,
    NavigationChanged,
    PlanSwitched,
    RoomNamed,
    StatusNote,
    TelemetryUpdated,
)
from giraff_console.tui.robot_keys import RobotKeys
from giraff_console.tui.room_palette import RoomCommands
from giraff_console.tui.status_log import StatusLog
from giraff_console.tui.top_bar import TopBar
from giraff_console.tui.transcript import Transcript

# Keys 1-5 of the thesis (B.7 SetResolution).
RESOLUTIONS = dict(enumerate(CAMERA_RESOLUTIONS, start=1))
# What the command line takes beside the robot's commands (service/commands.py).
CONSOLE_COMMANDS = [
    ("help", "show this screen"),
    ("quit", "leave (the console in its own process stops the robot first)"),
    ("fast, canny, markers", "switch a camera processor on or off (markers: outlines, ids)"),
    *c.HELP_LINES,
    ("set NAME VALUE", "send a controller command, e.g. set v 0.3 (checked against the limits)"),
    ("get NAME", "read a parameter, e.g. get bulk_data"),
    ("home", "any other bare controller command"),
]
# The layouts of the centre that M steps through: camera and map, the map, the camera.
LAYOUTS = ("both", "map", "camera")


class GiraffConsole(RobotKeys, KeyGuard):
    """The operator's screen on the robot service, in this process or the daemon's."""

    CSS_PATH = "app.tcss"
    TITLE = "giraff-console"
    COMMANDS = KeyGuard.COMMANDS | {RoomCommands}
    # Nothing takes the focus by itself: the keys belong to driving until Enter is pressed.
    AUTO_FOCUS = None
    BINDINGS = [
        # Ctrl-C too, so that there is one way to quit and one question: Textual's own
        # asked its own, a third way out.
        Binding("escape,ctrl+c", "quit", "Quit", key_display="esc", id="quit",
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
        Binding("ctrl+t", "take", "Take", show=False, id="take",
                tooltip="take the controls from the console that holds them (then y)"),
        Binding("question_mark", "help", "Help", id="help", tooltip="this screen"),
    ]  # fmt: skip
    # Priority: the app takes each key as it arrives, in the order typed. Otherwise a key
    # goes round through the screen and comes back late, behind the keys typed after it:
    # under load Enter opened the command line after the next keys had run their
    # bindings (issue 12). check_action hands the keys on while a screen is on top.
    BINDINGS = [replace(b, priority=True) for b in BINDINGS if isinstance(b, Binding)]

    def __init__(
        self,
        robot: Robot,
        *,
        clock: Clock,
        simulator: bool,
        attached: str | None = None,
        camera: CameraFeed | None = None,
        play: Path | None = None,
        plan: FloorPlan | None = None,
        walls: OccupancyGrid | None = None,
        undock_distance: float = 0.3,
        battery_low: float = 25.0,
        started: Callable[[], None] = lambda: None,
        stop: Callable[[], object] = lambda: None,
        timestamp: Callable[[], str] = lambda: time.strftime("%H:%M:%S"),
        cursor_blink: bool = True,
        crashed: Callable[[BaseException], None] = lambda error: None,
    ) -> None:
        """`robot` is the service the console asks, in its own process or `attached` to a
        daemon (whose address that is). `plan` and its `walls` are what the map draws;
        `started` runs the robot once the screen hears it (the tests on a virtual clock
        tick the loop themselves), and `stop` stops it for good as the console leaves;
        `battery_low` is the percent below which the top line
        shows the battery LOW."""
        super().__init__()
        self.robot = robot
        self.clock = clock
        self.attached = attached
        self.camera = camera
        self.play_at_start = play
        self.plan = plan
        self.walls = walls
        self.route: RouteShown | None = None
        self._shown_route: RouteShown | None = None
        # Where the robot is, until the first snapshot says (within a tick of starting).
        self.pose = Pose()
        # Lines for the status log once it is on screen (how the console was set up).
        self.notes_at_start: list[str] = []
        self._scene: MapScene | None = None
        self._layout = 0
        self.simulator = simulator
        self.undock_distance = undock_distance
        self.battery_low = battery_low
        # The latest snapshot: the stalk keys step from the height it reports.
        self.telemetry: Telemetry | None = None
        self.controls: Controls | None = None
        # Why the daemon this console is attached to has gone, while it is gone.
        self.disconnected: str | None = None
        # Attached: the daemon's frames are drawn here, for the pane's size in cells; the
        # last one drawn, and the picture it made.
        self._renderer = HalfBlockRenderer(os.environ.get("COLORTERM") in ("truecolor", "24bit"))
        self._cells = (80, 20)
        self._shared: tuple[bytes, tuple[int, int], CameraPicture] | None = None
        self.started = started
        self.stop_robot = stop
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
        yield KeysFooter()

    def on_mount(self) -> None:
        self.top_bar = self.query_one(TopBar)
        self.main_view = self.query_one(MainView)
        self.status_log = self.query_one(StatusLog)
        self.transcript = self.query_one(Transcript)
        self.camera_view = self.query_one(CameraView)
        self.map_view = self.query_one(MapView)
        if self.plan is not None and self.walls is not None:
            self._scene = plan_scene(self.plan, self.walls)
            self._show_map()
        else:
            self.map_view.display = False  # nothing to draw: the camera has the room
        self.robot.subscribe(self._from_robot, vital=True)
        if self.attached is not None:
            self.note(f"attached to the robot's daemon at {self.attached}: quitting leaves "
                      "its missions running")  # fmt: skip
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
        elif self.attached is not None:
            # The daemon's camera, in frames it shares; drawn here at this pane's size.
            self.camera_view.on_size = self._pane_size
            self.call_after_refresh(lambda: self._pane_size(*self.camera_view.size))
            self._watch_camera()
        # The robot runs once the screen hears it (its first notes are not lost) and has
        # been drawn once: its threads do not hold up the first screen (issue 26).
        self.call_after_refresh(self._start)

    def _start(self) -> None:
        """The robot running, then the session asked for played back on it."""
        self.started()
        if self.play_at_start is not None:
            self.order(c.Play(self.play_at_start))

    def _handle_exception(self, error: Exception) -> None:
        # An exception in a handler or a worker: the robot is stopped before anything
        # else, then Textual reports it and closes the console (design.md).
        self.crashed(error)
        super()._handle_exception(error)

    def on_unmount(self) -> None:
        self.robot.unsubscribe(self._from_robot)
        self.robot.close()
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

    # -- from the robot -----------------------------------------------------------------

    def on_telemetry_updated(self, message: TelemetryUpdated) -> None:
        now = self.clock.now()
        self._frames = [t for t in self._frames if now - t < 1.0] + [now]
        self.top_bar.ui_fps = float(len(self._frames))
        telemetry = self.telemetry = message.telemetry
        self.top_bar.recording = telemetry.recording
        self._moving = telemetry.intent is not None or (
            telemetry.state is not None and telemetry.state.moving
        )
        self.top_bar.show(message.telemetry)
        self.main_view.show(message.telemetry)
        # Every snapshot: the map view draws again only if what it shows has changed.
        self.pose = message.telemetry.pose
        self._show_map()

    def on_navigation_changed(self, message: NavigationChanged) -> None:
        self.route = message.route
        self._show_map()

    def on_room_named(self, message: RoomNamed) -> None:
        """The map and the room lists by the new name: the console's copy of the plan,
        renamed as the service renamed its own."""
        plan, renamed = self.plan, message.renamed
        if plan is None or renamed.old not in plan.rooms:
            return
        try:
            plan = self.plan = room_names.renamed(plan, renamed.old, renamed.new)
        except room_names.RenameError as error:
            self.note(f"the map keeps the old names: {error}")
            return
        if self.walls is not None:
            self._scene = plan_scene(plan, self.walls)
            self._show_map()

    def on_map_grown(self, message: MapGrown) -> None:
        """The map being built, drawn as it grows, in place of the plan's walls."""
        scene = self._scene
        grid = message.grid
        self._scene = replace(scene, walls=grid) if scene is not None else MapScene(grid)
        self.map_view.display = True
        self.map_view.regrid(located(self._scene, self.pose, None))

    def on_plan_switched(self, message: PlanSwitched) -> None:
        """The plan a saved map made: its rooms and doors from now on."""
        self.plan, self.walls = message.plan, message.walls
        if message.walls is None:
            # A plan of points alone (the dock, before a map): nothing to draw.
            self._scene = None
            self.map_view.display = False
            return
        self._scene = plan_scene(message.plan, message.walls)
        self.map_view.display = True
        self.map_view.regrid(located(self._scene, self.pose, None))

    def on_controls_changed(self, message: ControlsChanged) -> None:
        before, controls = self.controls, message.controls
        self.controls = controls
        if self.attached is None or (before is not None and before.holder == controls.holder):
            return  # alone in its process it always holds them; a console came or went
        holder = controls.holder
        mine = self.robot_console()
        if holder == mine:
            self.note("you hold the controls")
        else:
            self.note(f"watching: {holder or 'nobody'} holds the controls (Ctrl+T takes them)")

    def on_daemon_left(self, message: DaemonLeft) -> None:
        self.disconnected = message.why
        self._moving = False
        self.top_bar.show_disconnected(True)
        self.note(f"DISCONNECTED: {message.why}; the keys do nothing until a daemon is back, "
                  "and this console attaches again by itself")  # fmt: skip

    def on_daemon_back(self, message: DaemonBack) -> None:
        self.disconnected = None
        self.top_bar.show_disconnected(False)
        self.note(f"attached again to the robot's daemon at {self.attached}")
        self._watch_camera()
        for text in self.welcomed(message.welcome):
            self.note(text)
        self.controls = message.welcome.controls
        self.route = message.welcome.route
        self._show_map()

    def welcomed(self, welcome: Welcome) -> list[str]:
        """What a daemon's welcome says to the operator: how the last mission ended, what
        runs, and who holds the controls."""
        said = []
        situation = welcome.situation
        last = situation.last_mission
        if last is not None and last.end is not None:
            said.append(f"the last mission, {last.name}, ended: {last.end.words}")
        if situation.mission is not None:
            said.append(f"running now: {situation.mission}")
        holder = welcome.controls.holder
        watching = f"watching: {holder or 'nobody'} holds the controls (Ctrl+T takes them)"
        said.append("you hold the controls" if holder == welcome.console else watching)
        return said

    def robot_console(self) -> str | None:
        """This console's name as the daemon knows it (None in its own process)."""
        return getattr(self.robot, "console", None)

    def _show_map(self) -> None:
        """Draw the robot where it is, with the route and the doors as they are now."""
        if self._scene is None:
            return
        route = self.route
        if route is not None and route is not self._shown_route:
            self._shown_route = route
            closed = set(route.closed)
            doors = tuple(replace(door, open=door.id not in closed) for door in self._scene.doors)
            self._scene = replace(self._scene, doors=doors, path=route.path,
                                  obstacles=route.obstacles)  # fmt: skip
        estimate = self.telemetry.estimate if self.telemetry is not None else None
        self._scene = located(self._scene, self.pose, estimate)
        self.map_view.show(self._scene)

    def on_exchange_seen(self, message: ExchangeSeen) -> None:
        self.transcript.add(message.exchange)

    def on_status_note(self, message: StatusNote) -> None:
        self.note(message.text)

    def on_answer(self, message: Answer) -> None:
        reply = message.reply
        if reply.text:
            self.note(reply.text)
        for line in reply.lines:
            self.note(line)
        request = message.request
        if reply.ok and isinstance(request, c.Play) and not request.stop:
            self.transcript.separator("playback")

    def note(self, text: str) -> None:
        self.status_log.note(f"{self.timestamp()} {text}")

    def _from_robot(self, event: ServiceEvent) -> None:
        """Whatever the robot says, as a message from its thread to the screen."""
        if isinstance(event, Telemetry):
            self.post_message(TelemetryUpdated(event))
        elif isinstance(event, Note):
            self.post_message(StatusNote(event.text))
        elif isinstance(event, Exchange):
            self.post_message(ExchangeSeen(event))
        elif isinstance(event, RouteShown):
            self.post_message(NavigationChanged(event))
        elif isinstance(event, Controls):
            self.post_message(ControlsChanged(event))
        elif isinstance(event, RoomRenamed):
            self.post_message(RoomNamed(event))
        elif isinstance(event, Disconnected):
            self.post_message(DaemonLeft(event.why))
        elif isinstance(event, Attached):
            self.post_message(DaemonBack(event.welcome))
        elif isinstance(event, SharedFrame):
            self._draw_shared(event)
        elif isinstance(event, MapDrawn):
            grid = picture_grid(event)
            if grid is not None:
                self.post_message(MapGrown(grid))
        elif isinstance(event, PlanChanged):
            self._switch_plan(event.path)

    def _switch_plan(self, path: Path) -> None:
        """The plan the robot now plans on, read here (on the robot's thread: reading a
        grid takes a moment) for the map and the room names."""
        try:
            plan = load_floorplan(path)
            walls = walls_of(plan)
        except (FloorPlanError, OSError) as error:
            self.post_message(StatusNote(f"the map still shows the old plan: {error}"))
            return
        self.post_message(PlanSwitched(plan, walls))

    def _pane_size(self, columns: int, rows: int) -> None:
        self._cells = (max(1, columns), max(1, rows))

    def _draw_shared(self, frame: SharedFrame) -> None:
        """A frame the daemon shared, drawn for the pane on the reading thread; the same
        picture again (a robot standing still) only says its new rate."""
        last = self._shared
        cells = self._cells
        if last is not None and last[0] == frame.jpeg and last[1] == cells:
            picture = replace(last[2], fps=frame.fps, markers=frame.markers)
        else:
            try:
                picture = picture_of(frame, self._renderer, cells)
            except SharedFrameError as error:
                self.post_message(StatusNote(f"camera: {error}"))
                return
        self._shared = (frame.jpeg, cells, picture)
        self.post_message(CameraPictureUpdated(picture))

    def _post(self, message: Message) -> None:
        """`post_message` for the callbacks the services make, which return nothing."""
        self.post_message(message)

    # -- requests -----------------------------------------------------------------------

    def order(self, request: c.Request) -> None:
        """Ask the robot; the answer goes to the status log. A key, a stop, is asked on
        this thread, in the order typed; the others (planning a route takes a few hundred
        milliseconds) in a worker, so that the keys are answered meanwhile."""
        if self.disconnected is not None:
            # No daemon to ask: the keys do nothing until one is back. A stop says so,
            # once for each press, so that nobody believes it was sent.
            if isinstance(request, c.Halt):
                self.note("stop not sent: disconnected from the daemon")
            return
        if request.quick:
            self.robot.post(request, lambda reply: self._post(Answer(request, reply)))
        else:
            self._order_slowly(request)

    @work(thread=True, group="orders")
    def _order_slowly(self, request: c.Request) -> None:
        self.robot.post(request, lambda reply: self._post(Answer(request, reply)))

    # -- keys ---------------------------------------------------------------------------

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

    def action_take(self) -> None:
        controls = self.controls
        holder = controls.holder if controls is not None else None
        if self.attached is None or holder == self.robot_console():
            self.note("you hold the controls")
            return
        self.ask(f"take the controls from {holder or 'nobody'}? y takes them, any other key "
                 "does not", {"y"}, lambda: self.order(c.TakeControls()))  # fmt: skip

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
        if self.camera is not None:
            # Hidden, the camera is not drawn (camera/feed.py).
            self.camera.shown = LAYOUTS[self._layout] != "map"
        elif self.attached is not None:
            self._watch_camera()

    def _watch_camera(self) -> None:
        """Attached: ask the daemon for the camera's frames while the pane shows, and
        for none while it does not (camera/shared_frame.py)."""
        self.order(c.View(on=LAYOUTS[self._layout] != "map"))

    def action_zoom(self, factor: float) -> None:
        self.map_view.zoom(factor)

    def action_pan(self, columns: int, rows: int) -> None:
        self.map_view.pan(columns, rows)

    def action_follow(self) -> None:
        self.map_view.centre_on_robot()

    def action_help(self) -> None:
        self.push_screen(HelpScreen(list(self.BINDINGS), CONSOLE_COMMANDS))

    async def action_quit(self) -> None:
        """Esc, q, Ctrl-C: ask first while anything runs, or right after the command line
        closed, where a second Esc meant for the line would otherwise quit."""
        self._quit(ask=self.quit_is_hasty())

    def _quit(self, ask: bool) -> None:
        busy = self._busy()
        if busy or ask:
            why = f"{busy}: " if busy else ""
            leave = "leaves" if self.attached is not None else "stops the robot and leaves"
            self.ask(f"quit? {why}y {leave}, any other key stays", {"y"}, self._leave)
        else:
            self._leave()

    def _busy(self) -> str:
        """What would be cut short by quitting now, or ''. Attached, only the keys held:
        the daemon carries on with the rest."""
        telemetry = self.telemetry
        if self.attached is not None:
            held = telemetry is not None and telemetry.intent is not None
            return "the robot is moving" if held else ""
        if telemetry is not None and telemetry.mission is not None:
            return f"{telemetry.mission.name} is running"
        if telemetry is not None and telemetry.recording:
            return "recording"
        if self._moving:
            return "the robot is moving"
        return ""

    def _leave(self) -> None:
        if self.attached is None:
            self.note("stopping the robot and leaving")
            # Stop first: the app takes a while to close its screens after exit().
            self.stop_robot()
        self.exit()

    def _navigation_words(self) -> list[str]:
        """What the command line offers to complete: every room and door by name."""
        if self.plan is None:
            return []
        rooms = [f"go {room_id}" for room_id in sorted(self.plan.rooms)]
        doors = sorted(door.id for door in self.plan.doors)
        return rooms + [f"close {door}" for door in doors] + [f"open {door}" for door in doors]

    def closed_doors(self) -> frozenset[str]:
        """The doors shut now, as the robot last said."""
        return frozenset(self.route.closed) if self.route is not None else frozenset()

    # -- the command line ---------------------------------------------------------------

    def run_command(self, text: str) -> None:
        """A console command, a robot's (service/commands.py), or a controller command
        checked against the limits."""
        word = text.split(maxsplit=1)[0] if text.strip() else ""
        if word == "help":
            self.action_help()
        elif word == "quit":
            self._quit(ask=False)  # typed in full: asks only while something runs
        elif word in ("fast", "canny", "markers"):
            self.action_processor(word)
        elif word == "take":
            self.action_take()
        else:
            try:
                request = c.parse(text)
            except c.Usage as error:
                self.note(f"refused: {error}{self._choices(word)}")
                return
            if isinstance(request, c.Go):
                self.note(f"planning a route to {request.room} ...")
            self.order(request if request is not None else c.Send(text))

    def _choices(self, word: str) -> str:
        """What there is to choose from, for a command typed without it."""
        plan = self.plan
        if plan is None or word not in ("go", "close", "open"):
            return ""
        if word == "go":
            return f"; rooms: {', '.join(sorted(plan.rooms))}"
        return f"; doors: {', '.join(sorted(door.id for door in plan.doors))}"
