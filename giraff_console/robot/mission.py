"""What the control loop runs when the robot drives itself (design.md, missions/).

A mission is stepped by the control loop, on its thread, once per tick and whenever
the time it asked for comes: it gets the latest motor state and answers with the
commands to send now. The loop checks every command against the same limits as typed
commands (knowing the speed just polled), stops the mission when the operator takes the
keys, on ESTOP, when the link is lost and when the mission reports a problem, and stops
the robot when a mission is stopped or paused.

A mission says how it is getting on as data, a `Progress`: each front end draws it in
its own way (the TUI with Textual's widgets, the CLI with rich's), and where there is
only text (a log, a pipe) `Progress.line` gives the line operators know.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from giraff_console.link.motor_state import MotorState
from giraff_console.protocol.codec import Command

# What a mission under way says it is doing when its figures say it all.
DRIVING = "driving"
PAUSED = "paused"
ARRIVED = "arrived"
# The text bar's width, in characters: as wide as it has always been in the main view.
TEXT_BAR = 16


class Outcome(enum.Enum):
    """How a mission ended: a type, so that no front end decides by comparing the words
    (issue 26). `value` is what `--json` prints. A mission that drives to a place judges
    its own end (the first seven); the loop ends missions from outside too, and says
    why in the rest."""

    # There, and the pose confirmed by a marker recently enough (missions/certainty.py).
    ARRIVED = "arrived"
    # There by the estimate, but nothing has confirmed it lately: dead reckoning, or no
    # marker in sight at the goal. The detail says how far it drove on the odometry.
    ARRIVED_UNVERIFIED = "arrived_unverified"
    # Touched something again and again, and backing off and trying again did not help.
    STALLED = "stalled"
    # No way there, or no nearer for too long.
    BLOCKED = "blocked"
    # No marker seen to find the robot by where it needed one, or a pose that jumped or
    # cannot be trusted (robot/odometry_feed.py).
    LOST = "lost"
    # Not started: where the robot stands is only assumed, and nothing can confirm it.
    UNVERIFIED = "unverified"
    # Something else it cannot go on with (the board's readings, a bad plan).
    FAILED = "failed"
    # Did all it set out to do, and judges no arrival (an undock, a route replayed).
    DONE = "done"
    # The operator stopped it: the stop key, the driving keys, a console's `stop`, the
    # program on the virtual port (§4.5).
    STOPPED_BY_OPERATOR = "stopped_by_operator"
    # The board's emergency stop is raised.
    ESTOP = "estop"
    # No link to the board, the link lost, or the board restarted under it.
    LINK_LOST = "link_lost"
    # The board, or the limits every command passes, refused what it asked for.
    REFUSED = "refused"
    # Another mission or a playback took its place, or it was stopped before it started.
    CANCELLED = "cancelled"
    # The loop would not start it: a playback runs, or the pose cannot be trusted.
    NOT_STARTED = "not_started"
    # Stopped for safety: a signal (the SSH connection dropped), the console closing, a
    # crash, the operator no longer told.
    HALTED = "halted"

    @property
    def arrived(self) -> bool:
        """At the goal, confirmed or not."""
        return self in (Outcome.ARRIVED, Outcome.ARRIVED_UNVERIFIED)


@dataclass(frozen=True)
class MissionEnd:
    """How a mission ended: its `outcome`, which decides; `why`, the loop's words for
    the operator ("done", "stopped by ESTOP", "stopped: the link to the board was
    lost"); and `detail`, the mission's own words on its outcome, if it judged it."""

    outcome: Outcome
    why: str
    detail: str = ""

    @property
    def words(self) -> str:
        """What the operator reads: the mission's own words, else the loop's."""
        return self.detail or self.why


@dataclass(frozen=True)
class Progress:
    """Where a mission is, for the operator.

    `state` says what it is doing, in the robot's terms: DRIVING, PAUSED, ARRIVED, "no
    nearer for 12 s", "stopping to plan a new way (a door closed on the route)", a
    patrol's "round 2/3, stop 4/32 (kitchen)". The figures are None where there is no
    honest one to give: `left_m` and `total_m` (the length of the plan under way, which
    a bar measures `left_m` against) for a mission that drives no planned path;
    `left_m` while it looks for a marker or stops to plan again, where the braking
    metres of the plan given up would read as nearly there; `eta_s` then too, and while
    paused. `detail` is how the part under way of a mission made of others is getting
    on: a patrol's stop, its detour to the dock. `brief` is the state in fewer words for
    a narrow screen (issue 26: at 80x24 the main view is some 34 columns), leaving out
    what the detail's name or the map says already: a patrol's "stop 4/32" for "round
    1/1, stop 4/32 (room-110)"; None where the state is as short as it gets.
    """

    name: str
    state: str
    left_m: float | None = None
    total_m: float | None = None
    eta_s: float | None = None
    detail: Progress | None = None
    brief: str | None = None

    @property
    def done_m(self) -> float | None:
        """How far along the plan under way, for a bar: none of it while the metres
        left are not known."""
        if self.total_m is None:
            return None
        if self.left_m is None:
            return 0.0
        return max(self.total_m - self.left_m, 0.0)

    def words(self, brief: bool = False) -> str:
        """What the mission is doing and what it has left, as said after its name and
        bar: metres left and an ETA for a path; time left for what has no metres; "no
        ETA" for a path whose metres left are not known.

        `brief`, for a narrow screen: the figures first, since what is left is what the
        operator looks for and the end of a line is what a narrow screen cuts, in fewer
        characters, then the `brief` state: "3.0 m, ETA 0:07", "5:02 left, stop 1/6"."""
        state = self.brief if brief and self.brief is not None else self.state
        said = [] if state == DRIVING else [state]
        minutes, seconds = divmod(round(self.eta_s or 0.0), 60)
        figures = []
        if self.left_m is not None:
            figures.append(f"{self.left_m:.1f} m" if brief else f"{self.left_m:.1f} m left")
            if self.eta_s is not None:
                figures.append(f"ETA {minutes}:{seconds:02d}")
        elif self.eta_s is not None:
            if brief:
                figures.append(f"{minutes}:{seconds:02d} left")
            else:
                figures.append(f"{minutes} min {seconds:02d} s left" if minutes else
                               f"{seconds} s left")  # fmt: skip
        elif self.total_m is not None:
            figures.append("no ETA")
        said = [*figures, *said] if brief else [*said, *figures]
        return ", ".join(part for part in said if part)

    def line(self) -> str:
        """The one line the operator reads where there is only text: the name, a text
        bar along a planned path, then the words; a progress with no figures of its own
        goes on with its detail's line. "go day-room ███░░░░░░░░░░░░░ 35.4 m left, ETA
        1:31", "patrol tour3: round 3/3, stop 4/32 (room-110), 7 s left"."""
        words = self.words()
        head = self.name
        if self.total_m is not None:
            done = self.done_m or 0.0
            filled = round(TEXT_BAR * done / max(self.total_m, 1e-9))
            head = f"{head} {'█' * filled}{'░' * (TEXT_BAR - filled)}"
        elif words:
            head = f"{head}:"
        text = f"{head} {words}" if words else head
        if self.detail is not None and self.left_m is None and self.eta_s is None:
            text = f"{text}: {self.detail.line()}"
        return text


class Mission(Protocol):
    """Something that drives the robot by itself: a route replay, a patrol."""

    name: str

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        """The commands to send at `now`, in order; `state` is the latest poll."""
        ...

    def next_due(self) -> float | None:
        """When the mission next wants to be stepped, if sooner than the next tick."""
        ...

    def pause(self, now: float) -> None:
        """Hold still from `now`; the loop has stopped the robot."""
        ...

    def resume(self, now: float) -> None:
        """Carry on from where `pause` left off."""
        ...

    @property
    def finished(self) -> bool: ...

    @property
    def problem(self) -> str | None:
        """Why the mission cannot go on (a stall, no way left), if it cannot; the loop
        then stops the robot and ends it."""
        ...

    @property
    def progress(self) -> Progress:
        """Where the mission is and how long it has left."""
        ...


@runtime_checkable
class Judged(Protocol):
    """A mission that says how it ended (a path mission: go, dock, a route followed),
    for whoever reports the end: the loop's MissionChanged carries it."""

    @property
    def outcome(self) -> Outcome | None: ...

    @property
    def detail(self) -> str: ...
