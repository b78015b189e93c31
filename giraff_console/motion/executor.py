"""Driving a shaped path on the board: commands streamed every control tick (§2.7, A.2).

The board plans its own moves: from the speed it has, it ramps at `a` to `v`, and
stops at `p` metres (or degrees) from where it was told; in curved motion its gear
ratio ramps from where it is towards `vg` at `vgr` per metre (A.2.3). It keeps doing
the last move it was given if the console goes away, so every tick renews a short move
(never further ahead than the console's reach, robot/safety.py: design.md's runaway
rule with a margin) chosen so that, for one tick, the board does what the plan wants:

- `v` is the planned speed one tick from now and `a` the acceleration that reaches it in
  that tick, so the speed follows the jerk-limited profile tick by tick. `a` is never
  below what stops the robot within `p` from the speed it may have by then: that is
  what bounds a runaway, and it keeps the board's own stop out of the tick.
- `vg` is the curvature the path has where the robot will be at the next tick, plus a
  steering correction, less the turn the casters are expected to add after a turn on
  the spot (§3.2.1.5, robot/ekf.py), and `vgr` the ramp that reaches it over the distance of that
  tick. The path's curvature is piecewise linear in distance, so the ramps reproduce it,
  and the ratio never jumps: it only ever ramps, and `vgr` is never zero (§3.2.1.4).
- Where the robot is, the pose estimate says; the steering correction takes the robot back to
  it when it drifts (§2.3.1): a curvature of -(e_y / L^2 + 2 e_h / L) for a lateral
  error e_y and a heading error e_h, which settles over a distance of about L, without
  overshoot.

Turns on the spot are streamed the same way, in the rotation style (r = 0), where `p`
is degrees and positive turns right (A.2.2). A `Reverse` (backing clear of something the
robot touched) is a straight drive with `p` negative and no gear ratio.

A stall (motion commanded, the wheels not turning: §2.3.2) is the executor's `problem`,
and `stalled` says that is what it is, for a mission that recovers from it; `halt`
then stops the board's move at once, where `brake` would ease off along the path.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import ruckig

from giraff_console.link.motor_state import MotorState
from giraff_console.motion.path import Drive, Reverse, Rotation, Section, gear_of, wrap
from giraff_console.motion.speed_profile import (
    MotionLimits,
    Profile,
    SlowZone,
    drive_profile,
    move_profile,
    rotation_profile,
)
from giraff_console.protocol.codec import Command, Number, format_number
from giraff_console.protocol.kinematics import TURN_FACTOR_DEG_PER_M, TURN_RADIUS_M
from giraff_console.robot.odometry import Pose
from giraff_console.robot.safety import REACH_M, RUNAWAY_M, rotation_wheel_speed

# How far ahead each move reaches: under the console's reach (REACH_M), with 1 cm to
# spare for the poll and the commands that a tick takes on a real serial line.
LOOKAHEAD_M = REACH_M - 0.01
PATH_STYLE, ROTATE_STYLE = 1000, 0
# Steering correction: it settles over about this distance (the L above).
STEER_DISTANCE_M = 0.4
STEER_MAX_CURVATURE = 0.6
# The board's gear ratio limit (§3.2.1.4), and the ramps the executor may ask for.
MAX_GEAR = 0.5
GEAR_RATE_RANGE = (0.05, 2.0)  # per metre: never zero, which would jump (A.2.3)
# Speeds (m/s) below which the board is given this much instead: it takes no zero speed.
MIN_SPEED = 0.002
# A section is done when this little is left and the board has stopped; once its
# profile is over, when this much is: a real board's moves miss by a few millimetres
# (§5.5), and chasing the last of them would hunt back and forth.
DONE_M = 0.002
SETTLE_M = 0.005
SETTLE_TURN_M = 0.003  # wheel metres: 0.7 degrees
# The speed at which a robot that fell behind its profile covers the rest.
CREEP_SPEED = 0.05
# Motion commanded but the wheels not turning for this long is a stall (§2.3.2).
STALL_S = 1.0
STALL_M = 0.001
# How much of the difference between the profile's clock and the robot's place is taken
# up each tick, and the part of the jerk limit the profile is planned with, the rest
# being left for that.
PLAN_PULL = 0.2
JERK_SPARE = 0.85
# The most the pull may run the profile's clock faster or slower, as a fraction of the
# time passing (see _advance_plan).
PULL_MAX = 0.04
# Below this acceleration (m/s^2) a pull's change is bounded as if at this one: where
# the profile cruises, moving its clock changes the speed by little, but not by nothing.
PULL_ACCEL_FLOOR = 0.05
# Values are sent to a tenth of a millimetre: finer changes are not worth a command.
DECIMALS = 4


@dataclass
class Trace:
    """What was commanded and what the board did, tick by tick, for the report."""

    times: list[float]
    speeds: list[float]  # commanded v, m/s (wheel m/s while turning on the spot)
    gear_jumps: int = 0
    stops: list[float] = field(default_factory=list)
    # Where each section's ticks begin in `times`: a drive and a turn on the spot are
    # different motions, each from rest to rest, so no jerk is taken across them.
    starts: list[int] = field(default_factory=list)

    def max_jerk(self) -> float:
        """The largest change of commanded acceleration per second, tick to tick, within
        a section; each starts from rest."""
        jerk = 0.0
        t, v = self.times, self.speeds
        starts = set(self.starts)
        for i in range(2, len(t)):
            if i in starts or i - 1 in starts:
                continue
            dt1, dt0 = t[i] - t[i - 1], t[i - 1] - t[i - 2]
            if dt1 <= 0 or dt0 <= 0:
                continue
            change = (v[i] - v[i - 1]) / dt1 - (v[i - 1] - v[i - 2]) / dt0
            jerk = max(jerk, abs(change) / ((dt1 + dt0) / 2))
        return jerk


class Executor:
    """Streams one shaped path to the board; `step` once per control tick."""

    def __init__(
        self,
        sections: Sequence[Section],
        limits: MotionLimits,
        tick: float,
        zones: Callable[[Drive], Sequence[SlowZone]] = lambda drive: (),
    ) -> None:
        self.sections = list(sections)
        self.limits = limits
        self.tick = tick
        self.profiles = _profiles(self.sections, replace(limits, j_max=limits.j_max * JERK_SPARE),
                                  zones)  # fmt: skip
        # The jerk-limited optimum for the whole path at the limits themselves.
        self.time_optimal = sum(p.duration for p in _profiles(self.sections, limits, zones))
        self.index = 0
        self.problem: str | None = None
        self.stalled = False  # the problem is a stall (see the module docstring)
        self.trace = Trace([], [])
        self._t0: float | None = None
        self._base = (0.0, 0.0)
        self._sent: dict[str, str] = {}
        self._vgr = 0.0
        self._last: tuple[float, float] | None = None  # (cvg, path metres) at the last tick
        # When the wheels last turned, and where they were then: for stalls.
        self._still_since: tuple[float, tuple[float, float]] | None = None
        self._progress = 0.0
        self._plan_time = 0.0  # where the present section's profile is, in its own time
        self._pull = 0.0  # how much faster than time the profile's clock runs, towards the robot
        self._plan_clock: float | None = None  # when _plan_time was last advanced
        self._creep_since: float | None = None  # when the profile ran out short of the end
        self._creep_plan: Profile | None = None  # the move over what it left
        # A turn on the spot: the odometry's heading at its start, and the angle to turn.
        self._start_heading: float | None = None
        self._turn = 0.0
        # A stop asked for mid-drive: when it began, its speed curve, the path metres
        # there and how far it takes.
        self._brake: tuple[float, ruckig.Trajectory, float, float] | None = None
        self._brake_ended = False  # the board's last move replaced by one to stop at once

    @property
    def finished(self) -> bool:
        return self.index >= len(self.sections)

    def remaining(self) -> float:
        """Path metres still to drive (turns on the spot count their wheel travel)."""
        if self.finished:
            return 0.0
        later = sum(profile.length for profile in self.profiles[self.index + 1 :])
        return max(0.0, self.profiles[self.index].length - self._progress) + later

    def remaining_time(self, now: float) -> float:
        """Seconds of the plan still to go."""
        if self.finished:
            return 0.0
        later = sum(profile.duration for profile in self.profiles[self.index + 1 :])
        return max(0.0, self.profiles[self.index].duration - self._plan_time) + later

    def brake(self, now: float) -> None:
        """Stop as soon as the jerk limit allows, along the path, and end there (something
        is in the way). A turn on the spot is finished first: it goes nowhere."""
        if self._brake is not None:
            return  # stopping already
        if self.finished or self._t0 is None:
            self.abandon()
            return
        if isinstance(self.sections[self.index], Rotation | Reverse):
            self.sections = self.sections[: self.index + 1]
            self.profiles = self.profiles[: self.index + 1]
            return
        speed = self.trace.speeds[-1] if self.trace.speeds else 0.0
        limits = self.limits
        stop = ruckig.InputParameter(1)
        stop.control_interface = ruckig.ControlInterface.Velocity
        stop.current_position, stop.current_velocity = [0.0], [speed]
        stop.current_acceleration = [self._accel_now()]
        stop.target_velocity, stop.target_acceleration = [0.0], [0.0]
        stop.max_velocity = [limits.v_max]
        stop.max_acceleration, stop.max_jerk = [limits.a_max], [limits.j_max]
        curve = ruckig.Trajectory(1)
        ruckig.Ruckig(1).calculate(stop, curve)
        distance = curve.at_time(curve.duration)[0][0]
        self._brake = (now, curve, self._progress, distance)
        self.sections = self.sections[: self.index + 1]
        self.profiles = self.profiles[: self.index + 1]

    def abandon(self) -> None:
        """Give the rest up (the robot was stopped by other means): finished at once."""
        self.sections = self.sections[: self.index]
        self.profiles = self.profiles[: self.index]

    @property
    def style(self) -> int | None:
        """The movement style (`r`) last sent to the board, if any: what a stop's `p`
        means (A.2)."""
        sent = self._sent.get("r")
        return None if sent is None else int(sent)

    @property
    def progress(self) -> float:
        """Metres (wheel metres turning on the spot) done of the present section."""
        return self._progress

    def _accel_now(self) -> float:
        """The commanded acceleration of the last tick, from the speeds commanded."""
        speeds, times = self.trace.speeds, self.trace.times
        if len(speeds) < 2 or times[-1] <= times[-2]:
            return 0.0
        accel = (speeds[-1] - speeds[-2]) / (times[-1] - times[-2])
        return max(-self.limits.a_max, min(self.limits.a_max, accel))

    def forget_board(self) -> None:
        """The board's settings are unknown (it was stopped by someone else): send all."""
        self._sent.clear()

    def step(self, now: float, state: MotorState, pose: Pose,
             casters: float = 0.0) -> list[Command]:  # fmt: skip
        """The commands for this tick; the section moves on when the board has stopped
        at the end of the one before. `casters` is the turn (radians per metre driven,
        positive left) the casters are expected to add now, after a turn on the spot
        (§3.2.1.5; robot/ekf.py): a drive steers against it."""
        if self.finished or self.problem is not None:
            return []
        if state.imdl is None or state.imdr is None:
            self.problem = "the board does not report wheel distances (imdl, imdr)"
            return []
        if self._t0 is None:
            self._t0, self._base = now, (state.imdl, state.imdr)
            self.trace.starts.append(len(self.trace.times))
            self._last = None
            self._still_since = None
        section = self.sections[self.index]
        if isinstance(section, Drive):
            commands = self._drive(section, now, state, pose, casters)
        elif isinstance(section, Reverse):
            commands = self._reverse(section, now, state)
        else:
            commands = self._rotate(section, now, state, pose)
        if commands is None:  # the section is done; the next starts on the next tick
            if self.index + 1 < len(self.sections):
                self.trace.stops.append(now)
            self.index += 1
            self._t0 = self._plan_clock = self._creep_since = self._start_heading = None
            self._creep_plan = None
            self._progress = self._plan_time = 0.0
            return []
        self._check_stall(now, state)
        return commands

    # -- driving along the path ---------------------------------------------------------

    def _drive(self, drive: Drive, now: float, state: MotorState, pose: Pose,
               casters: float) -> list[Command] | None:  # fmt: skip
        profile = self.profiles[self.index]
        assert self._t0 is not None
        t = now - self._t0
        travelled = ((state.imdl or 0.0) - self._base[0] + (state.imdr or 0.0) - self._base[1]) / 2
        # Where the robot is along the path: the odometers, corrected by how far ahead
        # of or behind the path's point the pose is.
        near = drive.pose_at(travelled)
        dx, dy = pose.x - near.x, pose.y - near.y
        along = math.cos(near.heading) * dx + math.sin(near.heading) * dy
        s = min(max(travelled + along, 0.0), drive.length)
        here = drive.pose_at(s)
        lateral = -math.sin(here.heading) * (pose.x - here.x) + math.cos(here.heading) * (
            pose.y - here.y
        )
        heading_error = wrap(pose.heading - here.heading)
        self._progress = s
        remaining = drive.length - s
        speed = state.speed or 0.0
        self._note_gear(state, travelled)
        if self._brake is not None:
            began, curve, at, distance = self._brake
            remaining = max(0.0, at + distance - s)
            if (remaining <= DONE_M or now - began >= curve.duration) and not state.moving:
                return None
        elif not state.moving and (
            remaining <= DONE_M or (t >= profile.duration and remaining <= SETTLE_M)
        ):
            return None
        plan_t = self._advance_plan(profile, s, now)
        _, v_cmd, _ = profile.at(plan_t + self.tick)
        if self._brake is not None:
            began, curve, _, _ = self._brake
            v_cmd = curve.at_time(min(now - began + self.tick, curve.duration))[1][0]
        elif plan_t >= profile.duration:
            # Behind the plan at its end: creep the rest. At the profile's own end, not
            # the clock's: the pulled profile runs up to PULL_MAX behind the clock, and
            # a creep begun while its tail still moved met it in a kink (3.9 m/s^3 with
            # a board at 97 % of each command).
            v_cmd = max(v_cmd, self._creep(now, remaining))
        self._record(now, v_cmd)
        v_cmd = max(v_cmd, MIN_SPEED)
        # Steering: the path's curvature where the robot will be, plus the correction.
        ahead = s + max(speed, 0.0) * self.tick
        correction = -(lateral / STEER_DISTANCE_M**2 + 2 * heading_error / STEER_DISTANCE_M)
        correction = max(-STEER_MAX_CURVATURE, min(STEER_MAX_CURVATURE, correction))
        # Against the casters as well: they turn the robot as fast as 2.6 rad a metre
        # as it sets off after a turn on the spot (45 degrees settling by 1 - 1/e in
        # 0.3 m), far past what the correction may steer, and on a short run (onto the
        # dock, through a doorway) the robot would be off line by the time it had
        # steered back. Steering against what they are expected to do takes that out
        # as it happens; the correction takes out the rest. The gear ratio's limit
        # bounds it all.
        curvature = drive.curvature_at(ahead) + correction - casters
        gear = max(-MAX_GEAR, min(MAX_GEAR, gear_of(curvature)))
        # In a curve the outer wheel goes 1 + |vg| times as far as the middle (A.2.3),
        # with the ratio anywhere between the one there is and the one aimed at: the
        # outer wheel keeps within the reach.
        target = min(remaining, LOOKAHEAD_M / (1 + max(abs(gear), abs(state.cvg))))
        if target < 1e-4:
            if self._brake is None or not state.moving or self._brake_ended:
                return []  # stopping right there already
            # A brake just after setting off: the board is still on the move sent before
            # it, up to LOOKAHEAD_M at a creep, and would finish it: end it, once (a move
            # renewed every tick would never end).
            self._brake_ended = True
            target = 1e-4
        accel = self._accel(speed, v_cmd, target, ahead=remaining - speed * self.tick > DONE_M)
        rate = abs(gear - state.cvg) / max(max(speed, v_cmd) * self.tick, 0.005)
        rate = max(GEAR_RATE_RANGE[0], min(GEAR_RATE_RANGE[1], rate))
        # The sign of vgr says which way the turn goes (A.2.3): the way of the ratio
        # aimed at, or of the one there is when it is heading back to zero.
        turning = gear if gear != 0 else state.cvg
        self._vgr = rate if turning >= 0 else -rate
        return self._commands(
            {"r": PATH_STYLE, "mode": 0, "cdp": LOOKAHEAD_M, "a": accel, "v": v_cmd,
             "vg": gear, "vgr": self._vgr}, target)  # fmt: skip

    def _accel(self, speed: float, v_cmd: float, target: float, ahead: bool) -> float:
        """The acceleration that reaches `v_cmd` in a tick, but never below
        - what stops the robot within the runaway limit from the speed it may have by
          the time the move starts (the bound the control loop checks);
        - until the tick that reaches the target, what keeps the board's own stop at
          the target out of this tick, so that the board follows the profile rather
          than braking early; in that last tick, what stops it at the target."""
        limits, u = self.limits, abs(speed)
        runaway = (u + limits.a_max * self.tick) ** 2 / (2 * RUNAWAY_M)
        if ahead:
            stop = max(u, v_cmd) ** 2 / (2 * max(target - u * self.tick, 1e-3))
        else:
            stop = u * u / (2 * max(target, 1e-4))
        return min(max(abs(v_cmd - u) / self.tick, runaway, stop, 1e-3), limits.a_max)

    # -- backing up ---------------------------------------------------------------------

    def _reverse(self, section: Reverse, now: float, state: MotorState) -> list[Command] | None:
        """Straight back along the robot's heading, jerk-limited like a drive: no
        steering over a few decimetres, so the gear ratio ramps to zero and stays."""
        profile = self.profiles[self.index]
        assert self._t0 is not None
        t = now - self._t0
        travelled = -((state.imdl or 0.0) - self._base[0] + (state.imdr or 0.0) - self._base[1]) / 2
        s = min(max(travelled, 0.0), section.length)
        self._progress = s
        remaining = section.length - s
        speed = abs(state.speed or 0.0)
        if not state.moving and (
            remaining <= DONE_M or (t >= profile.duration and remaining <= SETTLE_M)
        ):
            return None
        plan_t = self._advance_plan(profile, s, now)
        _, v_cmd, _ = profile.at(plan_t + self.tick)
        if plan_t >= profile.duration:
            v_cmd = max(v_cmd, self._creep(now, remaining))
        self._record(now, v_cmd)
        v_cmd = max(v_cmd, MIN_SPEED)
        target = min(remaining, LOOKAHEAD_M)
        if target < 1e-4:
            return []
        accel = self._accel(speed, v_cmd, target, ahead=remaining - speed * self.tick > DONE_M)
        return self._commands({"r": PATH_STYLE, "mode": 0, "cdp": LOOKAHEAD_M, "a": accel,
                               "v": v_cmd, "vg": 0.0, "vgr": GEAR_RATE_RANGE[1]},
                              -target)  # fmt: skip

    # -- turning on the spot ------------------------------------------------------------

    def _rotate(self, rotation: Rotation, now: float, state: MotorState,
                pose: Pose) -> list[Command] | None:  # fmt: skip
        profile = self.profiles[self.index]
        assert self._t0 is not None
        t = now - self._t0
        way = 1.0 if rotation.angle > 0 else -1.0  # +1: left, counter-clockwise
        # What is left is measured from the odometry's heading, which is not wrapped: a
        # half turn has no ambiguity. The turn ends at the plan's heading, even if the
        # robot set off a little away from it.
        if self._start_heading is None:
            self._start_heading = pose.heading
            self._turn = rotation.angle + wrap(rotation.at.heading - pose.heading)
        left_to_turn = way * (self._turn - (pose.heading - self._start_heading))
        remaining = left_to_turn * TURN_RADIUS_M  # wheel metres
        self._progress = profile.length - remaining
        wheel = abs(rotation_wheel_speed(state, 0.0))
        settled = abs(remaining) <= DONE_M / 4 or (
            t >= profile.duration and abs(remaining) <= SETTLE_TURN_M
        )
        if settled:
            # Within the tolerance: the board finishes the move it has. Renewed now, every
            # set p would miss by its few millimetres again (§5.5) and the turn would hunt
            # round its end, for tens of seconds on the imperfect simulator.
            return None if not state.moving else []
        done = profile.length - remaining
        plan_t = self._advance_plan(profile, done, now)
        _, v_cmd, _ = profile.at(plan_t + self.tick)
        if plan_t >= profile.duration:
            v_cmd = max(v_cmd, self._creep(now, abs(remaining)))
        if abs(remaining) < 1e-4:
            return []
        self._record(now, v_cmd)
        v_cmd = max(v_cmd, MIN_SPEED)
        target = max(-LOOKAHEAD_M, min(LOOKAHEAD_M, remaining))
        accel = self._accel(wheel, v_cmd, abs(target),
                            ahead=abs(remaining) - wheel * self.tick > DONE_M)  # fmt: skip
        # set p in degrees, positive to the right (A.2.2): against our left-positive way.
        degrees = -way * target * TURN_FACTOR_DEG_PER_M
        return self._commands({"r": ROTATE_STYLE, "mode": 0, "a": accel, "v": v_cmd}, degrees)

    # -- shared -------------------------------------------------------------------------

    def _creep(self, now: float, remaining: float) -> float:
        """The speed to cover what the profile left over (a robot that fell behind it):
        a move of its own from rest over what is left, at most CREEP_SPEED and within
        the jerk limit all the way (a creep eased in and then held to the distance left
        changed its acceleration at once: 1.05 m/s^3 over the last 5 mm), followed to
        its end, and planned anew if the robot is still short once it has run out."""
        creep = self._creep_plan
        if creep is None or self._creep_since is None or now - self._creep_since > creep.duration:
            if remaining <= DONE_M:
                return 0.0
            limits = replace(self.limits, j_max=self.limits.j_max * JERK_SPARE)
            creep = self._creep_plan = move_profile(remaining, CREEP_SPEED, limits)
            self._creep_since = now
            self.trace.starts.append(len(self.trace.times))  # a move of its own, from rest
        return creep.at(now - self._creep_since + self.tick)[1]

    def _advance_plan(self, profile: Profile, done: float, now: float) -> float:
        """Where in its profile the section is: the clock's time since the last tick,
        nudged towards the moment the profile passes the robot's place. Following the
        clock alone, a robot a little behind at the end would be left short; following
        the place alone, the speed jitters at the start, where a millimetre is a long
        time. The nudge takes up a difference over a few ticks; the profile is planned
        with some of the jerk limit to spare for it (JERK_SPARE)."""
        if self._plan_clock is None:
            self._plan_time = 0.0
            self._pull = 0.0
        elif now > self._plan_clock:
            dt = now - self._plan_clock
            wanted = PLAN_PULL * (profile.time_at(done) - self._plan_time - dt) / dt
            # The pull is a second clock on top of the profile's, and it adds jerk two
            # ways: running the clock a fraction f faster scales the profile's own jerk
            # by (1 + f)^2 (the speed's third derivative in the clock's time, twice
            # over the tick), and a pull that changes from one tick to the next changes
            # the commanded acceleration by the profile's acceleration times that
            # change. So the pull is held within PULL_MAX of the tick, and its change to
            # what the jerk left spare (JERK_SPARE) then allows. Without this, a robot a
            # centimetre ahead of its profile in the last decimetres before it stops (a
            # marker's correction, issue 25), where a millimetre is a long time, was
            # pulled into a jerk of 3.8 m/s^3, and setting off into 1.04. The pull is a
            # rate, not so much a tick: a tick the executor was not stepped (its mission
            # busy with something else) would otherwise halve it, a step of 1.03.
            _, _, accel = profile.at(self._plan_time)
            spare = (1 - JERK_SPARE * (1 + PULL_MAX) ** 2) * self.limits.j_max * dt
            step = spare / max(abs(accel), PULL_ACCEL_FLOOR)
            wanted = max(-PULL_MAX, min(PULL_MAX, wanted))
            self._pull = max(self._pull - step, min(self._pull + step, wanted))
            self._plan_time += dt * (1 + self._pull)
        self._plan_clock = now
        return self._plan_time

    def _commands(self, settings: dict[str, Number], target: float) -> list[Command]:
        """The settings the board does not hold yet, then the move; `r` first, since
        changing the style resets the board's counters (A.4.8)."""
        commands = []
        for name, value in settings.items():
            if name == "a":
                # Rounded up: the acceleration is a floor that bounds the runaway.
                value = math.ceil(float(value) * 10**DECIMALS) / 10**DECIMALS
            elif name == "v":
                # Never past the top speed the guard holds: a brake begun while still
                # speeding up goes on speeding up until its jerk has turned the
                # acceleration round (ruckig's velocity interface keeps to the
                # acceleration and jerk limits, not to the speed), a millimetre a second
                # past the speed it began at, and at the top speed the guard refuses it.
                value = min(float(value), self.limits.v_max)
            text = format_number(round(float(value), DECIMALS) if name != "r" else value)
            if self._sent.get(name) != text:
                commands.append(Command("set", name, float(text) if "." in text else int(text)))
                self._sent[name] = text
        commands.append(Command("set", "p", round(target, DECIMALS)))
        return commands

    def _record(self, now: float, v_cmd: float) -> None:
        self.trace.times.append(now)
        self.trace.speeds.append(v_cmd)

    def _note_gear(self, state: MotorState, travelled: float) -> None:
        """Count gear ratio changes since the last tick beyond what the ramp asked for
        allows over the distance driven: a jump (§3.2.1.4). The board puts the ratio
        back to zero when a move ends; at a standstill that moves nothing."""
        if self._last is not None and state.moving:
            last_gear, last_s = self._last
            allowed = abs(self._vgr) * abs(travelled - last_s) + 1e-3
            if abs(state.cvg - last_gear) > allowed:
                self.trace.gear_jumps += 1
        self._last = (state.cvg, travelled)

    def _check_stall(self, now: float, state: MotorState) -> None:
        """Motion commanded for a while and the odometers not moving (§2.3.2)."""
        wheels = (state.imdl or 0.0, state.imdr or 0.0)
        commanded = bool(self.trace.speeds) and self.trace.speeds[-1] > 0.02
        if not commanded or self._still_since is None:
            self._still_since = (now, wheels)
            return
        since, then = self._still_since
        if max(abs(wheels[0] - then[0]), abs(wheels[1] - then[1])) > STALL_M:
            self._still_since = (now, wheels)
        elif now - since >= STALL_S:
            self.problem = f"stalled: the wheels have not turned for {now - since:.1f} s"
            self.stalled = True


def _profiles(sections: Sequence[Section], limits: MotionLimits,
              zones: Callable[[Drive], Sequence[SlowZone]]) -> list[Profile]:  # fmt: skip
    profiles = []
    for section in sections:
        if isinstance(section, Drive):
            profiles.append(drive_profile(section, limits, zones(section)))
        elif isinstance(section, Reverse):
            profiles.append(drive_profile(section.ahead(), limits))
        else:
            profiles.append(rotation_profile(section, limits))
    return profiles
