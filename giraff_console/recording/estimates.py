"""The pose filter's estimate, kept beside the control log as `estimate.jsonl` (issue 14).

The control log stays the original console's format (§3.2.1.1, B.2), which the original
reads and which has no room for a pose, let alone its covariance; so the estimate goes
to a file of its own, one JSON object a line, in time order:

    {"t": 1.25, "pose": [x, y, heading], "odometry": [x, y, heading],
     "covariance": [[..3..], [..3..], [..3..]], "sigma_m": .., "sigma_heading": ..,
     "ellipse": [semi_major, semi_minor, angle], "landmarks": true, "found": true,
     "seen": [7], "rejected": [], "corrected_at": 1.2}

`t` and `corrected_at` are seconds into the session, on the control log's clock; `t` is
to the millisecond, as the log's times are, so that an estimate published right after a
poll is never read as coming before it. Poses are metres and radians, the covariance
(x, y, heading)'s, row by row. Sessions recorded before the filter have no such file,
and play and export as they always did.

How often
    The loop publishes an estimate every tick (20 Hz), but between corrections the
    filter only carries its pose along by what the wheels did, which the control log
    already records: playback redoes that (robot/replay.py). So an estimate is written
    whenever it stops following the odometry (`follows`: a marker corrected it, the
    robot was placed, the odometry jumped), whenever what it says about markers changes,
    and otherwise every ESTIMATE_INTERVAL_S, for the covariance, which grows smoothly as
    the robot drives. That is about a quarter of the ticks: some 8 MB an hour, a small
    part of what the video takes.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from giraff_console.recording.control_log import LogProblem, parse_lines

ESTIMATES = "estimate.jsonl"
# 5 Hz: the covariance, the one thing playback cannot carry along, is at most this old.
ESTIMATE_INTERVAL_S = 0.2
# An estimate whose place relative to the odometry's moved by more than this no longer
# follows it; the filter's own prediction and the odometry's agree far better than that.
FOLLOW_M = 1e-4
FOLLOW_RAD = 1e-4

Triple = tuple[float, float, float]


@dataclass(frozen=True)
class RecordedEstimate:
    """One line of estimate.jsonl: robot/localisation.py's Estimate as of `offset`
    seconds into the session, with poses as (x, y, heading) and `corrected_at` in
    seconds into the session too."""

    offset: float
    pose: Triple
    odometry: Triple
    covariance: tuple[Triple, Triple, Triple]
    sigma_m: float
    sigma_heading: float
    ellipse: Triple
    landmarks: bool = False
    found: bool = False
    seen: tuple[int, ...] = ()
    rejected: tuple[int, ...] = ()
    corrected_at: float | None = None
    line_no: int = 0

    def finite(self) -> bool:
        """No number is infinite or NaN (a filter not yet placed has an infinite
        covariance: nothing worth keeping, and nothing JSON can hold)."""
        numbers = [self.offset, *self.pose, *self.odometry, *self.ellipse, self.sigma_m,
                   self.sigma_heading, *(v for row in self.covariance for v in row)]  # fmt: skip
        if self.corrected_at is not None:
            numbers.append(self.corrected_at)
        return all(math.isfinite(number) for number in numbers)


@dataclass(frozen=True)
class EstimatesRead:
    """What estimate.jsonl held: the usable lines, in time order, and those skipped."""

    entries: list[RecordedEstimate]
    problems: list[LogProblem]


def format_estimate(estimate: RecordedEstimate) -> str:
    """One line of estimate.jsonl, without its line end. The estimate's numbers are
    written in full (repr), so that what is read back is exactly what was recorded."""
    body = {
        "t": round(estimate.offset, 3),
        "pose": list(estimate.pose),
        "odometry": list(estimate.odometry),
        "covariance": [list(row) for row in estimate.covariance],
        "sigma_m": estimate.sigma_m,
        "sigma_heading": estimate.sigma_heading,
        "ellipse": list(estimate.ellipse),
        "landmarks": estimate.landmarks,
        "found": estimate.found,
        "seen": list(estimate.seen),
        "rejected": list(estimate.rejected),
        "corrected_at": estimate.corrected_at,
    }
    return json.dumps(body, separators=(",", ":"), allow_nan=False)


def parse_estimate(text: str, line_no: int = 0) -> RecordedEstimate:
    """Parse one line; ValueError says what is wrong with it. Keys it does not know are
    ignored, so that a later console may add some."""
    try:
        body = json.loads(text, parse_constant=_no_constant)
    except RecursionError:
        raise ValueError("nested too deeply") from None
    except ValueError as error:
        raise ValueError(f"not JSON ({str(error)[:80]})") from None
    if not isinstance(body, dict):
        raise ValueError("not a JSON object")
    corrected = body.get("corrected_at")
    return RecordedEstimate(
        offset=_time(body.get("t"), "t"),
        pose=_triple(body, "pose"),
        odometry=_triple(body, "odometry"),
        covariance=_covariance(body.get("covariance")),
        sigma_m=_number(body.get("sigma_m"), "sigma_m"),
        sigma_heading=_number(body.get("sigma_heading"), "sigma_heading"),
        ellipse=_triple(body, "ellipse"),
        landmarks=_flag(body, "landmarks"),
        found=_flag(body, "found"),
        seen=_ids(body, "seen"),
        rejected=_ids(body, "rejected"),
        corrected_at=None if corrected is None else _number(corrected, "corrected_at"),
        line_no=line_no,
    )


def parse_estimates(lines: Iterable[str]) -> EstimatesRead:
    """Every usable line of estimate.jsonl; corrupt lines are reported and skipped, as
    the control log's are (control_log.parse_log). The last of `lines` is the text after
    the last line end, which a recording cut off (a crash, a power loss) leaves
    unfinished."""
    entries, problems = parse_lines(lines, parse_estimate)
    return EstimatesRead(entries, problems)


def follows(earlier: RecordedEstimate, later: RecordedEstimate) -> bool:
    """`later` is `earlier` carried along by the odometry alone, and says the same about
    markers. Both then moved by the same steps, each in its own frame, so the rigid move
    of the map that takes the odometry's pose onto the estimate's is unchanged."""
    if (earlier.found, earlier.landmarks, earlier.seen, earlier.rejected,
            earlier.corrected_at) != (later.found, later.landmarks, later.seen,
                                      later.rejected, later.corrected_at):  # fmt: skip
        return False
    before, after = _odometry_to_estimate(earlier), _odometry_to_estimate(later)
    turned = math.remainder(after[2] - before[2], math.tau)
    return math.dist(before[:2], after[:2]) <= FOLLOW_M and abs(turned) <= FOLLOW_RAD


def _odometry_to_estimate(estimate: RecordedEstimate) -> Triple:
    """The move of the map (a shift after a turn about the origin) that takes the
    odometry's pose onto the estimate's."""
    (x, y, heading), (ox, oy, oheading) = estimate.pose, estimate.odometry
    turn = heading - oheading
    cos_t, sin_t = math.cos(turn), math.sin(turn)
    return x - (cos_t * ox - sin_t * oy), y - (sin_t * ox + cos_t * oy), turn


def _no_constant(text: str) -> float:
    raise ValueError(f"{text} is not a number")


def _number(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{name}: not a number")
    try:
        number = float(value)
    except OverflowError:
        number = math.inf
    if not math.isfinite(number):
        raise ValueError(f"{name}: out of range")
    return number


def _time(value: Any, name: str) -> float:
    number = _number(value, name)
    if number < 0:
        raise ValueError(f"{name}: before the session began")
    return number


def _covariance(value: Any) -> tuple[Triple, Triple, Triple]:
    if not isinstance(value, list) or len(value) != 3:
        raise ValueError("covariance: not 3 rows")
    first, second, third = (_three(row, "covariance") for row in value)
    return first, second, third


def _three(value: Any, name: str) -> Triple:
    if not isinstance(value, list) or len(value) != 3:
        raise ValueError(f"{name}: not a list of 3 numbers")
    first, second, third = (_number(item, name) for item in value)
    return first, second, third


def _triple(body: dict[str, Any], name: str) -> Triple:
    return _three(body.get(name), name)


def _flag(body: dict[str, Any], name: str) -> bool:
    value = body.get(name)
    if not isinstance(value, bool):
        raise ValueError(f"{name}: not true or false")
    return value


def _ids(body: dict[str, Any], name: str) -> tuple[int, ...]:
    value = body.get(name)
    if not isinstance(value, list) or not all(
        isinstance(item, int) and not isinstance(item, bool) and item >= 0 for item in value
    ):
        raise ValueError(f"{name}: not a list of marker ids")
    return tuple(value)
