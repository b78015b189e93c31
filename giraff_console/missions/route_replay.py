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

Open-loop as it is, a replay still watches the wheels: a move under way (the board
reports MOVING) with the wheels not turning for a second is a stall (§2.3.2, the same
test as a path mission's: motion/executor.py), the robot pushed up against something or
its wheels held. The replay ends there, STALLED: the rest of the route would start from
the wrong place, and a replay left to finish would be reported done when its last leg
never moved (issue 26). It does not back off and try again, as a path mission does:
it has no pose to steer back by.
"""

from __future__ import annotations

import math

from giraff_console.link.motor_state import MotorState
from giraff_console.missions.certainty import blind
from giraff_console.missions.follow_route import START_REACH_M
from giraff_console.missions.route import MOTION_SETTINGS, Route
from giraff_console.motion.executor import STALL_M, STALL_S
from giraff_console.motion.path import wrap
from giraff_console.protocol.codec import Command, format_number, parse_number
from giraff_console.protocol.kinematics import TURN_FACTOR_DEG_PER_M
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.mission import Outcome, Progress
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
    """A Mission that drives a taught route again; Judged: a stall ends it STALLED."""

    def __init__(self, route: Route) -> None:
        self.route = route
        self.name = route.name
        # Open-loop, the only thing it finds out is a stall; then all three say so.
        self.problem: str | None = None
        self.outcome: Outcome | None = None
        self.detail = ""
        # Since when, and from what wheel travel (imdl, imdr), a move has been under way
        # without the wheels turning; None while none is.
        self._still_since: tuple[float, tuple[float, float]] | None = None
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
        if self._paused_at is not None or self.finished or self.problem is not None:
            return []
        self._now = now
        if state is not None:
            self._watch_wheels(now, state)
            if self.problem is not None:
                return []
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

    def _watch_wheels(self, now: float, state: MotorState) -> None:
        """A stall: the board's move under way, the wheels not turning STALL_M in STALL_S.
        The wheel travel is the loop's totals (robot/odometry_feed.py), compared by
        differences."""
        wheels = (state.imdl or 0.0, state.imdr or 0.0)
        since = self._still_since
        turned = since is not None and max(abs(wheels[0] - since[1][0]),
                                           abs(wheels[1] - since[1][1])) > STALL_M  # fmt: skip
        if not state.moving or since is None or turned:
            self._still_since = (now, wheels) if state.moving else None
            return
        if now - since[0] < STALL_S:
            return
        self.outcome = Outcome.STALLED
        self.detail = (f"stalled {round(self.elapsed)} s into the route's "
                       f"{round(self.route.duration)} s: the wheels have not turned for "
                       f"{now - since[0]:.1f} s; a replay drives blind and cannot go round "
                       f"what is in the way")  # fmt: skip
        self.problem = self.detail

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
        self._still_since = None  # the loop stopped the robot: a new move starts from rest

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
