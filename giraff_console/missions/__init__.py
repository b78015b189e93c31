"""Missions: the robot driving itself, stepped by the control loop (robot/mission.py).

Taught routes replayed open-loop (§2.6.1) and patrols chained from them (§1.2, §2.5).
Going to a named room needs the planner (§2.6.2-§2.6.4) and arrives with it.
"""

from giraff_console.missions.patrol import (
    Patrol,
    PatrolError,
    PatrolRun,
    Stop,
    StopReached,
    list_patrols,
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
