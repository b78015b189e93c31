"""Arriving: when a path mission at the end of its plan may say it has arrived, and what
it does when it may not yet (issues 14 and 25).

With markers the robot has arrived once the estimate is confirmed (certainty.py) and
at the goal; else it looks for a marker, comes in again, or turns on the spot to the
goal's heading. Having come in again, it settles within AFTER_REAPPROACH_M. After
ARRIVAL_TRIES of those it settles for what it has, within the bounds every stop must
keep (claimed only with two sigma to spare), or gives up and says how far off it is.
The claim itself is honest (issue 25): ARRIVED only on a trusted estimate, a fresh
marker fix within the arrival bounds; otherwise ARRIVED_UNVERIFIED, with the metres
driven since a marker (or the range sensor's fit to the plan) last fixed the pose.
Without markers there is only the odometry, and the range sensor's fits where there is
one: arrived, unverified, at once.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from giraff_console.missions.certainty import (
    AFTER_REAPPROACH_M,
    ARRIVAL_TRIES,
    NEAR_ENOUGH_HEADING,
    NEAR_ENOUGH_M,
    REAPPROACH_M,
    confirmed,
    trusted,
)
from giraff_console.motion.path import wrap
from giraff_console.motion.shaping import ALIGNED_RAD
from giraff_console.robot.localisation import Estimate, PoseBasis
from giraff_console.robot.odometry import Pose

Point = tuple[float, float]


class Verdict(enum.Enum):
    """What the robot does at the end of its plan (module docstring)."""

    ARRIVED = "arrived"  # trusted: the claim
    UNCONFIRMED = "arrived, unconfirmed"  # there, but not known well enough to claim it
    LOOK = "look for a marker"
    COME_IN_AGAIN = "come in again"
    TURN = "turn to the goal's heading"
    GIVE_UP = "give up"  # too far off after all its tries


@dataclass(frozen=True)
class Judgement:
    verdict: Verdict
    detail: str  # the words for an end, or why it does what it does
    off: float  # metres from the goal, by the estimate
    settled: bool = False  # out of tries: as near as it could get


class Arrival:
    """The judging of one approach to a goal, and its tries; see the module docstring."""

    def __init__(self) -> None:
        self.tries = 0
        self.came_in_again = False  # so it settles within AFTER_REAPPROACH_M
        # The estimate is taken as it is: a look found no better, or the plan under way
        # is the turn to the goal's heading after one.
        self.as_known = False

    def anew(self) -> None:
        """A way round, or from wherever it was driven by hand, is a new approach: its
        arrival is judged afresh, with all its tries."""
        self.tries = 0
        self.came_in_again = False

    def looked(self, found: bool) -> None:
        """A look at the goal has ended: without a marker found, looking again would
        find no better."""
        self.as_known = not found

    def judge(self, pose: Pose, estimate: Estimate, goal: Point,
              heading: float | None) -> Judgement:  # fmt: skip
        """What the robot at `pose`, known as `estimate`, does at the end of its plan to
        `goal` (and `heading`, radians, if the goal has one)."""
        off = math.dist((pose.x, pose.y), goal)
        near = AFTER_REAPPROACH_M if self.came_in_again else REAPPROACH_M
        turned = heading is not None and abs(wrap(heading - pose.heading)) > ALIGNED_RAD
        # The turn to the goal's heading after a look adds only the wheels' error over
        # that turn, which looking again, turning away and back, would not take out.
        known = self.as_known or confirmed(estimate)
        if known and off <= near and not turned:
            return _claim(estimate, "arrived", off)
        if self.tries >= ARRIVAL_TRIES:
            askew = 0.0 if heading is None else abs(wrap(heading - pose.heading))
            if off > NEAR_ENOUGH_M or askew > NEAR_ENOUGH_HEADING:
                return Judgement(Verdict.GIVE_UP, (
                    f"could not get nearer than {off:.2f} m and {math.degrees(askew):.0f}° "
                    f"to the goal (by the estimate, known to ±{estimate.sigma_m:.2f} m) "
                    f"after {ARRIVAL_TRIES} tries"), off)  # fmt: skip
            if not _surely_within(estimate, off, askew):
                return Judgement(Verdict.UNCONFIRMED, unconfirmed(estimate), off, settled=True)
            return _claim(estimate, "arrived as near as it could", off, settled=True)
        self.tries += 1
        self.as_known = False
        if not known:
            return Judgement(Verdict.LOOK, f"arrived, known to ±{estimate.sigma_m:.2f} m", off)
        if off > near:
            self.came_in_again = True
            return Judgement(Verdict.COME_IN_AGAIN, f"{off:.2f} m off the goal by the markers",
                             off)  # fmt: skip
        self.as_known = True
        return Judgement(Verdict.TURN, "at the goal", off)


def _surely_within(estimate: Estimate, off: float, askew: float) -> bool:
    """A robot settling for what it has, `off` metres and `askew` radians from its goal
    by the estimate, is within the bounds every stop must keep in truth with two sigma
    to spare (95 %): at the arrival bound's 2.5 cm, 5 cm off is the most it may claim."""
    return (off + 2 * estimate.sigma_m <= NEAR_ENOUGH_M
            and askew + 2 * estimate.sigma_heading <= NEAR_ENOUGH_HEADING)  # fmt: skip


def _claim(estimate: Estimate, words: str, off: float, settled: bool = False) -> Judgement:
    if trusted(estimate):
        return Judgement(Verdict.ARRIVED, words, off, settled)
    return Judgement(Verdict.UNCONFIRMED, unconfirmed(estimate), off, settled)


def unconfirmed(estimate: Estimate) -> str:
    """What an arrival the estimate cannot vouch for says of it."""
    contact = ", touched something since" if estimate.contact else ""
    return (
        f"arrived, unconfirmed: known to ±{estimate.sigma_m:.2f} m and "
        f"±{math.degrees(estimate.sigma_heading):.1f}°, "
        f"{estimate.since_fix_m:.1f} m driven since its last fix"
        f"{contact}"
    )


def by_odometry(estimate: Estimate | None) -> str:
    """What an arrival without markers to confirm it says of it: by the odometry, and
    by the range sensor's fits to the plan's walls if they fixed the pose."""
    if estimate is None:
        return "arrived by the odometry alone"
    if estimate.basis is PoseBasis.SCAN:
        return (
            "arrived by the odometry and the range sensor's fits to the plan: "
            f"{estimate.since_fix_m:.1f} m driven since its last fix"
        )
    return (
        f"arrived by the odometry alone: {estimate.since_fix_m:.1f} m driven since "
        "the start last said where it was"
    )
