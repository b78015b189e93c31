"""Replaying a taught route open-loop, as §2.6.1 describes: "replays the recorded actions".

The replay starts from the board settings teaching began with, then resends what
teleop sent, at the times it was sent. Nothing is corrected: this is the dead-reckoning
patrol §5.6 wished it had tried, so the robot goes roughly where it went before,
drifting with the casters (§3.2.1.5) and blind to whatever moved into the way (§2.6.1's
"obvious problem"). The recorded `set p` renewals carry the lookahead of the teleop
that taught them, which may have reached further than today's: each is cut to the
console's reach (robot/safety.py), so that a console that dies mid-replay still stops
the robot within the runaway limit (design.md). A renewal comes every tick or two, so
a shorter one changes nothing of the route while the console lives.
"""

from __future__ import annotations

import math

from giraff_console.link.motor_state import MotorState
from giraff_console.missions.certainty import blind
from giraff_console.missions.follow_route import START_REACH_M
from giraff_console.missions.route import MOTION_SETTINGS, Route
from giraff_console.motion.path import wrap
from giraff_console.protocol.codec import Command, format_number, parse_number
from giraff_console.protocol.kinematics import TURN_FACTOR_DEG_PER_M
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.mission import Progress
from giraff_console.robot.safety import REACH_M

# A replay follows no pose, so it drives the taught shape from wherever the robot
# stands: it starts only as near where the route did as follow-route does (by the
# estimate), and turned no further from the route's first heading than this. 15 degrees
# off is 0.26 m sideways after a metre, about the most a doorway leaves either side.
REPLAY_TURN = math.radians(15.0)


def replay_refusal(route: Route, estimate: Estimate | None, retry: str) -> str | None:
    """Why `route` must not be replayed from where the robot stands, if it must not: the
    pose is only assumed (certainty.blind), or a localised robot stands away from, or
    turned from, the route's start (a patrol's stop before failed, or the robot was
    moved). None without localisation (no floor plan): the odometry then is the route's
    own frame only within one session, and the thesis's replay is all there is."""
    refusal = blind(estimate, retry)
    if refusal is not None or estimate is None or not route.path:
        return refusal
    start, pose = route.path[0], estimate.pose
    away = math.dist((pose.x, pose.y), (start.x, start.y))
    turned = abs(wrap(pose.heading - start.heading))
    if away <= START_REACH_M and turned <= REPLAY_TURN:
        return None
    return (f"the robot stands {away:.1f} m and {math.degrees(turned):.0f}° from where route "
            f"{route.name} starts, and a replay follows no pose: drive it there (within "
            f"{START_REACH_M:.0f} m and {math.degrees(REPLAY_TURN):.0f}°), or follow-route "
            f"{route.name}, then {retry} again")  # fmt: skip


class RouteReplay:
    """A Mission that drives a taught route again."""

    # Open-loop: it never finds out that anything went wrong.
    problem: str | None = None

    def __init__(self, route: Route) -> None:
        self.route = route
        self.name = route.name
        self._t0: float | None = None
        self._now: float | None = None
        self._paused_at: float | None = None
        self._sent = 0
        self._sent_at = 0.0
        self._state: MotorState | None = None
        # What the board holds for its next move, as the replay has set it.
        self._board = {k: v for k, v in route.settings.items() if k in MOTION_SETTINGS}
        self._restore = False

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        """The starting settings first; then each taught command once its time has come."""
        self._state = state
        if self._paused_at is not None or self.finished:
            return []
        self._now = now
        commands: list[Command] = []
        if self._t0 is None or self._restore:
            # The loop stops the robot on a pause, with settings of its own (cdp, p),
            # so a resumed replay sets the board back to where the route had it.
            self._t0 = now if self._t0 is None else self._t0
            self._restore = False
            self._sent_at = now
            commands = [
                Command("set", k, parse_number(self._board[k]))
                for k in MOTION_SETTINGS
                if k in self._board
            ]
        taught = self.route.commands
        # A microsecond of grace: at the time next_due gave, its command must be due,
        # whatever the rounding of t0 + offset - t0.
        while self._sent < len(taught) and taught[self._sent].offset <= now - self._t0 + 1e-6:
            command = taught[self._sent].command
            if command.name == "p" and command.value is not None:
                command = self._within_reach(command)
            elif command.value is not None:
                # A route holds single-valued motion settings: a twm is taught as its sets.
                assert not isinstance(command.value, tuple)
                self._board[command.name] = format_number(command.value)
            commands.append(command)
            self._sent += 1
            self._sent_at = now
        return commands

    def _within_reach(self, target: Command) -> Command:
        """`target` (a `set p`) cut to the console's reach: degrees when turning on the
        spot (r <= 0, A.2.2); on a curve (r > 50) metres of the middle whose outer wheel
        goes 1 + |vg| times as far (A.2.3)."""
        style = float(self._board.get("r", "1000"))
        if style <= 0:
            reach = REACH_M * TURN_FACTOR_DEG_PER_M
        elif style > 50:
            reach = REACH_M / (1 + abs(float(self._board.get("vg", "0"))))
        else:
            reach = REACH_M
        value = float(target.value)  # type: ignore[arg-type]
        if abs(value) <= reach:
            return target
        return Command("set", "p", round(max(-reach, min(reach, value)), 4))

    def next_due(self) -> float | None:
        """When the next taught command is due; None before the start and once all are sent."""
        if self._t0 is None or self._paused_at is not None:
            return None
        if self._sent == len(self.route.commands):
            return None
        return self._t0 + self.route.commands[self._sent].offset

    def pause(self, now: float) -> None:
        if self._paused_at is None:
            self._paused_at = now

    def resume(self, now: float) -> None:
        """Carry on where the pause left off: the rest of the route is shifted by the pause."""
        if self._paused_at is None:
            return
        if self._t0 is not None:
            self._t0 += now - self._paused_at
            self._restore = True
        self._paused_at = None

    @property
    def finished(self) -> bool:
        """Every command sent, and the robot seen at rest by a poll made after the last one."""
        state = self._state
        return (
            self._t0 is not None
            and self._sent == len(self.route.commands)
            and state is not None
            and not state.moving
            and state.received_at > self._sent_at
        )

    @property
    def elapsed(self) -> float:
        """Seconds of the route driven so far, pauses left out."""
        at = self._paused_at if self._paused_at is not None else self._now
        if self._t0 is None or at is None:
            return 0.0
        return min(max(at - self._t0, 0.0), self.route.duration)

    @property
    def progress(self) -> Progress:
        """The seconds of the route replayed: open-loop, its taught duration is its ETA."""
        elapsed, duration = self.elapsed, self.route.duration
        return Progress(f"route {self.name}", f"{round(elapsed)} s of {round(duration)} s",
                        eta_s=duration - elapsed)  # fmt: skip
