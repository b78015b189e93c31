"""Patrols: taught routes driven round after round, stopping to look at each stop.

§1.2 looks ahead to "fully autonomous daily or nightly patrols, looking for anomalies",
and §2.5 has destinations chosen "by preprogramming some patrol route". Until the
console can plan its way to a room (§2.6.2, §2.6.3), a patrol is a chain of taught
routes (§2.6.1), each starting where the one before ended: the robot drives a route,
the console takes a picture for the caregiver, the robot waits there a while, then
drives on. Replays are open-loop, so the error of every round adds up: a patrol should
end where it began, where the operator can see how far it drifted.

A patrol file is `routes/<name>.patrol.yaml`; routes/README.md describes it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from giraff_console.link.motor_state import MotorState
from giraff_console.missions.route import Route
from giraff_console.missions.route_replay import RouteReplay
from giraff_console.missions.yaml_file import YamlFile
from giraff_console.protocol.codec import Command

PATROL_SUFFIX = ".patrol.yaml"


class PatrolError(Exception):
    """A patrol that cannot be read or run; the message says why."""


@dataclass(frozen=True)
class Stop:
    """Drive the taught route `route`, then wait `dwell` seconds where it ends."""

    route: str
    dwell: float


@dataclass(frozen=True)
class Patrol:
    """A patrol file: `rounds` times over, each stop in turn."""

    name: str
    rounds: int
    snapshots: bool
    stops: list[Stop]


@dataclass(frozen=True)
class StopReached:
    """The robot came to rest at the end of a stop's route; both numbers count from 1."""

    round: int
    stop_index: int
    route_name: str


def load_patrol(path: Path) -> Patrol:
    """Read a patrol file; PatrolError names the file and what is wrong with it."""
    file = YamlFile(Path(path), PatrolError)
    if not file.path.name.endswith(PATROL_SUFFIX):
        file.fail(f"a patrol file's name ends in {PATROL_SUFFIX}")
    name = file.name(file.path.name.removesuffix(PATROL_SUFFIX), "patrol")
    doc = file.mapping(required=("rounds", "stops"), optional=("snapshots",))
    rounds = doc["rounds"]
    if isinstance(rounds, bool) or not isinstance(rounds, int) or rounds < 1:
        file.fail(f"rounds should be a whole number, at least 1, not {rounds!r}")
    snapshots = doc.get("snapshots", True)
    if not isinstance(snapshots, bool):
        file.fail(f"snapshots should be true or false, not {snapshots!r}")
    stops = doc["stops"]
    if not isinstance(stops, list) or not stops:
        file.fail("stops should be a list of {route: NAME, dwell: SECONDS}, at least one")
    return Patrol(
        name, rounds, snapshots, [_stop(file, s, f"stops[{i}]") for i, s in enumerate(stops)]
    )


def list_patrols(directory: Path) -> list[str]:
    """The names of the patrols in `directory`, sorted."""
    return sorted(
        path.name.removesuffix(PATROL_SUFFIX) for path in Path(directory).glob(f"*{PATROL_SUFFIX}")
    )


def _stop(file: YamlFile, item: object, where: str) -> Stop:
    if isinstance(item, dict) and "place" in item:
        file.fail(f"{where}: places need route planning (go <room>), which is not built yet")
    fields = file.table(item, where, ("route", "dwell"), required=("route",))
    dwell = file.number(fields.get("dwell", 0), f"{where}.dwell", minimum=0)
    return Stop(file.name(fields["route"], "route"), dwell)


class PatrolRun:
    """A Mission that drives a patrol: each stop's route, a call to `on_stop`, a dwell.

    `on_stop` is called on the control loop's thread, as the robot comes to rest at the
    end of a route; the console takes its snapshot there, so it must not block.
    """

    def __init__(
        self,
        patrol: Patrol,
        routes: dict[str, Route],
        on_stop: Callable[[StopReached], None] = lambda stop: None,
    ) -> None:
        missing = sorted({stop.route for stop in patrol.stops} - routes.keys())
        if missing:
            raise PatrolError(
                f"patrol {patrol.name} needs routes not taught yet: {', '.join(missing)}"
            )
        self.patrol = patrol
        self.name = patrol.name
        self._routes = routes
        self._on_stop = on_stop
        # (round, stop index) for every stop of every round, in the order they are made.
        self._legs = [(n, i) for n in range(1, patrol.rounds + 1) for i in range(len(patrol.stops))]
        self._leg = 0
        self._replay = RouteReplay(routes[patrol.stops[0].route])
        self._dwell_end: float | None = None
        self._paused_at: float | None = None
        self._now: float | None = None

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        if self._paused_at is not None or self.finished:
            return []
        self._now = now
        if self._dwell_end is not None:
            if now < self._dwell_end:
                return []
            self._leg, self._dwell_end = self._leg + 1, None
            if self.finished:
                return []
            self._replay = RouteReplay(self._routes[self._stop().route])
        commands = self._replay.step(now, state)
        if self._replay.finished:
            round_number, index = self._legs[self._leg]
            self._on_stop(StopReached(round_number, index + 1, self._replay.name))
            self._dwell_end = now + self._stop().dwell
        return commands

    def next_due(self) -> float | None:
        """The end of the dwell, or when the route being driven next sends something."""
        if self._paused_at is not None or self.finished:
            return None
        return self._dwell_end if self._dwell_end is not None else self._replay.next_due()

    def pause(self, now: float) -> None:
        if self._paused_at is None:
            self._paused_at = now
            if self._dwell_end is None:
                self._replay.pause(now)

    def resume(self, now: float) -> None:
        """Carry on: the route from where it paused, or the rest of the dwell."""
        if self._paused_at is None:
            return
        if self._dwell_end is not None:
            self._dwell_end += now - self._paused_at
        else:
            self._replay.resume(now)
        self._paused_at = None

    @property
    def finished(self) -> bool:
        """True once the last dwell of the last round is over."""
        return self._leg == len(self._legs)

    @property
    def problem(self) -> str | None:
        return None if self.finished else self._replay.problem

    @property
    def time_left(self) -> float:
        """An estimate: what is left of this stop, then the taught durations and dwells."""
        if self.finished:
            return 0.0
        if self._dwell_end is None:
            left = self._replay.route.duration - self._replay.elapsed + self._stop().dwell
        else:
            at = self._paused_at if self._paused_at is not None else self._now
            left = max(self._dwell_end - (at or 0.0), 0.0)
        for _, index in self._legs[self._leg + 1 :]:
            stop = self.patrol.stops[index]
            left += self._routes[stop.route].duration + stop.dwell
        return left

    @property
    def progress(self) -> str:
        if self.finished:
            return f"patrol {self.name}: done, {self.patrol.rounds} rounds"
        round_number, index = self._legs[self._leg]
        return (
            f"patrol {self.name}: round {round_number}/{self.patrol.rounds}, "
            f"stop {index + 1}/{len(self.patrol.stops)} ({self._stop().route}), "
            f"{_minutes(self.time_left)} left"
        )

    def _stop(self) -> Stop:
        return self.patrol.stops[self._legs[self._leg][1]]


def _minutes(seconds: float) -> str:
    minutes, seconds = divmod(round(seconds), 60)
    return f"{minutes} min {seconds:02d} s" if minutes else f"{seconds} s"
