"""A watchdog on a path mission's progress: a mission that gets no nearer gives up.

The thesis leaves "getting there" (§2.7) to a planner that replans "whenever an obstacle
is detected" (§2.6.4), and says nothing of an obstacle that never goes away. Among frail
people a robot that stops and replans, again and again, beside something it cannot get
round, is worse than one that stops and asks: so a mission whose distance left has not
gone down by PROGRESS_M for `stuck_s` seconds, or that has replanned `max_replans` times
in a row without getting that much nearer, is stuck, and ends with the reason.
"""

from __future__ import annotations

from dataclasses import dataclass

# Less than this nearer to the goal is not progress: the odometry's jitter, a turn on
# the spot's last degrees, a creep against a box.
PROGRESS_M = 0.2
# Looks for a marker in a row without progress (missions/localising.py): a way along
# which the robot keeps losing itself as soon as it has looked needs the operator.
MAX_LOOKS = 3


@dataclass(frozen=True)
class Patience:
    """How long a mission may go without progress (settings' [motion] table)."""

    stuck_s: float = 30.0  # a care home's corridors: long enough for a person to pass
    max_replans: int = 5  # replans in a row without progress

    def __post_init__(self) -> None:
        if not 0 < self.stuck_s <= 3600:
            raise ValueError(f"motion.stuck_s must be in (0, 3600] s, not {self.stuck_s}")
        if not isinstance(self.max_replans, int) or not 1 <= self.max_replans <= 1000:
            raise ValueError(
                f"motion.max_replans must be a whole number in [1, 1000], not {self.max_replans}"
            )


class ProgressWatch:
    """The best distance left so far, and since when and over how many replans the
    mission has not bettered it by PROGRESS_M."""

    def __init__(self, patience: Patience, now: float, left: float) -> None:
        self.patience = patience
        self.replans = 0  # replans since the last progress
        self.looks = 0  # looks for a marker since the last progress
        self._best = left
        self._since = now

    def driven(self, now: float, left: float) -> None:
        """The plan under way has `left` metres to go at `now`."""
        if left <= self._best - PROGRESS_M:
            self._best, self._since, self.replans, self.looks = left, now, 0, 0

    def replanned(self, left: float) -> None:
        """A new plan of `left` metres: a longer way round is not a step back, but it is
        a replan without progress until the robot gets PROGRESS_M along it."""
        self._best = left
        self.replans += 1

    def looked(self, seconds: float, left: float) -> None:
        """A look for a marker took `seconds`, and the new plan from where it put the
        robot is `left` metres: the time spent looking is not time stuck, and the way
        measured from a corrected pose is no step back, but a look without progress."""
        self._since += seconds
        self._best = left
        self.looks += 1

    def out_of_looks(self) -> bool:
        """Another look would be one too many without progress."""
        return self.looks >= MAX_LOOKS

    def restart(self, now: float) -> None:
        """The operator held the mission (pause): what came before does not count."""
        self._since, self.replans = now, 0

    def recovering(self, now: float) -> None:
        """A contact's recovery begins at `now` (recovery.py): backing off and looking
        are not time stuck, but a replan after it is one without progress."""
        self._since = now

    def still_for(self, now: float) -> float:
        """Seconds since the last progress."""
        return now - self._since

    def stuck(self, now: float) -> bool:
        """Too long without progress."""
        return self.still_for(now) >= self.patience.stuck_s

    def out_of_replans(self) -> bool:
        """Another replan would be one too many without progress."""
        return self.replans >= self.patience.max_replans
