"""Benchmark: grid planning with D* Lite against networkx A* from scratch (§2.6.4).

On 100x100 and 200x200 grids, random obstacles and rooms with doors, in one run:
- D* Lite's first plan;
- a replan after a few cells near the robot change (the robot moved three cells along
  its path, then found three cells just ahead of it blocked);
- re-routing when a door on the path closes (all of its cells blocked);
- each next to networkx A* from scratch on the same grid, whose graph is built before
  the timing starts, as a planner that kept its graph would.
And on the example care home, with the legs measured on its grid: the room-graph query
time once every leg is measured (what a console that has planned a while sees), next to
networkx A* on the same graph; and the time of a first route, measuring its legs as it
goes (LazySP), and of measuring every leg up front.

Usage: python bench/planning.py [--trials N] [--seed S]
"""

from __future__ import annotations

import argparse
import contextlib
import os
import platform
import random
import statistics
import time
from pathlib import Path

import networkx as nx
import numpy as np

import giraff_console
from giraff_console.planning.dstar_lite import DStarLite
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.legs import GridLegs
from giraff_console.planning.room_graph import RoomGraph
from giraff_console.planning.route_planner import ROBOT_RADIUS_M, walls_of

EXAMPLE = Path(__file__).resolve().parents[1] / "giraff_console/floorplans/care-home.yaml"

STRAIGHT, DIAGONAL = 10, 14


def grid_graph(blocked: np.ndarray) -> nx.Graph:
    """The same 8-connected, no-corner-cutting graph D* Lite plans on."""
    rows, cols = blocked.shape
    graph = nx.Graph()
    for r in range(rows):
        for c in range(cols):
            if blocked[r, c]:
                continue
            graph.add_node((r, c))
            for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
                rr, cc = r + dr, c + dc
                if not (0 <= rr < rows and 0 <= cc < cols) or blocked[rr, cc]:
                    continue
                if dr and dc and (blocked[r + dr, c] or blocked[r, c + dc]):
                    continue  # no corner cutting
                graph.add_edge((r, c), (rr, cc), weight=DIAGONAL if dr and dc else STRAIGHT)
    return graph


def octile(a: tuple[int, int], b: tuple[int, int]) -> int:
    dr, dc = abs(a[0] - b[0]), abs(a[1] - b[1])
    return STRAIGHT * max(dr, dc) + (DIAGONAL - STRAIGHT) * min(dr, dc)


def random_grid(size: int, rng: random.Random) -> np.ndarray:
    blocked = np.array([[rng.random() < 0.2 for _ in range(size)] for _ in range(size)])
    blocked[0, 0] = blocked[-1, -1] = False
    return blocked


def rooms_grid(size: int) -> tuple[np.ndarray, list[list[tuple[int, int]]]]:
    """Walls every size/5 cells both ways, with a door gap in each wall segment."""
    blocked = np.zeros((size, size), dtype=bool)
    step = size // 5
    doors = []
    for k in range(step, size, step):
        blocked[k, :] = True
        blocked[:, k] = True
    for k in range(step, size, step):
        for start in range(0, size, step):
            for gap in (
                [(k, c) for c in range(start + step // 2 - 1, start + step // 2 + 2)],
                [(r, k) for r in range(start + step // 2 - 1, start + step // 2 + 2)],
            ):
                gap = [cell for cell in gap if 0 <= cell[0] < size and 0 <= cell[1] < size]
                for cell in gap:
                    blocked[cell] = False
                doors.append(gap)
    for k in range(step, size, step):
        for j in range(step, size, step):
            blocked[k, j] = True
    return blocked, doors


def astar_ms(graph: nx.Graph, start, goal) -> float:
    begin = time.perf_counter()
    with contextlib.suppress(nx.NetworkXNoPath):  # the search ran all the same
        nx.astar_path(graph, start, goal, heuristic=octile, weight="weight")
    return (time.perf_counter() - begin) * 1e3


def timed(action) -> tuple[float, object]:
    begin = time.perf_counter()
    result = action()
    return (time.perf_counter() - begin) * 1e3, result


def trial(blocked: np.ndarray, doors) -> dict[str, float] | None:
    size = blocked.shape[0]
    start, goal = (0, 0), (size - 1, size - 1)
    planner = DStarLite(blocked, start, goal)
    first_ms, path = timed(planner.plan)
    if path is None or len(path) < 10:
        return None
    graph = grid_graph(blocked)
    result = {"first": first_ms, "astar": astar_ms(graph, start, goal)}
    # The robot moves three cells on, then finds three cells just ahead blocked.
    planner.move_to(path[3])
    ahead = [cell for cell in path[5:8] if cell != goal]
    changed = blocked.copy()
    for cell in ahead:
        changed[cell] = True
    planner.update_cells((cell, True) for cell in ahead)
    result["replan"], _ = timed(planner.plan)
    result["astar_replan"] = astar_ms(grid_graph(changed), path[3], goal)
    # A door the path goes through closes.
    on_path = set(path[3:])
    closing = next((door for door in doors if on_path & set(door)), None)
    if closing is not None:
        for cell in closing:
            changed[cell] = True
        planner.update_cells((cell, True) for cell in closing)
        result["door"], _ = timed(planner.plan)
        result["astar_door"] = astar_ms(grid_graph(changed), path[3], goal)
    return result


def room_graph_queries(count: int = 20000) -> None:
    """Every pair of rooms, again and again; then the same queries by networkx A*."""
    plan = load_floorplan(EXAMPLE)
    legs = GridLegs(plan, walls_of(plan).inflated(ROBOT_RADIUS_M))
    graph = RoomGraph(plan, legs.length)
    begin = time.perf_counter()
    graph.route("dock", "kitchen")
    first = (time.perf_counter() - begin) * 1e3
    begin = time.perf_counter()
    graph.measure_all()
    every = (time.perf_counter() - begin) * 1e3
    pairs = [(a, b) for a in plan.rooms for b in plan.rooms]
    begin = time.perf_counter()
    for i in range(count):
        graph.route(*pairs[i % len(pairs)])
    ours = (time.perf_counter() - begin) / count * 1e6
    nodes = graph.graph
    points = {node: data["xy"] for node, data in nodes.nodes(data=True)}
    begin = time.perf_counter()
    for i in range(count // 20):
        a, b = pairs[i % len(pairs)]
        nx.astar_path(
            nodes,
            ("room", a),
            ("room", b),
            weight="weight",
            heuristic=lambda u, v: float(np.hypot(*np.subtract(points[u], points[v]))),
        )
    peer = (time.perf_counter() - begin) / (count // 20) * 1e6
    print(
        f"room graph, {len(plan.rooms)} rooms {len(plan.doors)} doors, "
        f"{nodes.number_of_edges()} legs: query {ours:.2f} us, networkx A* {peer:.1f} us "
        f"({peer / ours:.0f}x); first route dock-kitchen {first:.0f} ms (legs measured as "
        f"needed), every leg measured {every:.0f} ms"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=10, help="grids per case (default 10)")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    rng = random.Random(args.seed)
    print(f"giraff-console {giraff_console.__version__}, Python {platform.python_version()}, "
          f"{platform.machine()}, {os.cpu_count()} cores")  # fmt: skip
    room_graph_queries()
    print(f"{'grid':<25}{'step':<31}{'D* Lite ms':>12}{'A* ms':>10}{'ratio':>8}")
    for size in (100, 200):
        for kind in ("random obstacles", "rooms with doors"):
            results = []
            while len(results) < args.trials:
                if kind == "random obstacles":
                    blocked, doors = random_grid(size, rng), []
                else:
                    blocked, doors = rooms_grid(size)
                outcome = trial(blocked, doors)
                if outcome is not None:
                    results.append(outcome)
            steps = [("first plan", "first", "astar"),
                     ("replan, 3 cells ahead blocked", "replan", "astar_replan"),
                     ("re-route, a door closes", "door", "astar_door")]  # fmt: skip
            for label, ours, peer in steps:
                pairs = [(r[ours], r[peer]) for r in results if ours in r]
                if not pairs:
                    continue
                median = statistics.median(p[0] for p in pairs)
                peer_median = statistics.median(p[1] for p in pairs)
                print(f"{size}x{size} {kind:<17}{label:<31}{median:>12.2f}{peer_median:>10.2f}"
                      f"{peer_median / median:>7.1f}x")  # fmt: skip


if __name__ == "__main__":
    main()
