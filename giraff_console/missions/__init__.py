"""Missions: the robot driving itself, stepped by the control loop (robot/mission.py).

Taught routes replayed open-loop (§2.6.1) and patrols chained from them (§1.2, §2.5).
Going to a named room needs the planner (§2.6.2-§2.6.4) and arrives with it.

The names below are imported on first use (PEP 562), not with the package: a light
module of it (names.py, patrol_log.py) must not pay for the planner, numpy and scipy
that patrol.py brings, since `--help` reads it (issue 26, item 6).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from giraff_console.missions.names import list_patrols
    from giraff_console.missions.patrol import (
        Patrol,
        PatrolError,
        PatrolRun,
        Stop,
        StopReached,
        load_patrol,
    )
    from giraff_console.missions.route import (
        Mark,
        PathSample,
        Route,
        RouteError,
        RouteTeacher,
        TimedCommand,
        list_routes,
        load_route,
        save_route,
    )
    from giraff_console.missions.route_replay import RouteReplay

# Where each name of the package lives.
_MODULES = {
    "giraff_console.missions.patrol": ("Patrol", "PatrolError", "PatrolRun", "Stop",
                                       "StopReached", "load_patrol"),
    "giraff_console.missions.names": ("list_patrols",),
    "giraff_console.missions.route": ("Mark", "PathSample", "Route", "RouteError",
                                      "RouteTeacher", "TimedCommand", "list_routes",
                                      "load_route", "save_route"),
    "giraff_console.missions.route_replay": ("RouteReplay",),
}  # fmt: skip
_HOME = {name: module for module, names in _MODULES.items() for name in names}


def __getattr__(name: str) -> object:
    if name not in _HOME:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(_HOME[name]), name)
    globals()[name] = value  # found directly from now on
    return value


__all__ = [
    "Mark",
    "PathSample",
    "Patrol",
    "PatrolError",
    "PatrolRun",
    "Route",
    "RouteError",
    "RouteReplay",
    "RouteTeacher",
    "Stop",
    "StopReached",
    "TimedCommand",
    "list_patrols",
    "list_routes",
    "load_patrol",
    "load_route",
    "save_route",
]
