"""Benchmark: route and grid planning at any size, beside compiled peers (issue 16).

In one run, on this machine:
- Room graphs of 32, 96 and 320 rooms (corridors with rooms either side, points and
  doors, straight legs): a door closing and opening (ours: mark the door; the former
  planner: networkx Dijkstra from every room, which it redid on each event; an eager
  all-pairs csgraph search for scale), then the first route after it, and a route
  looked up again.
- The example care home with its grid: the first route of a fresh planner for several
  pairs of rooms (every leg measured on the grid as the route needs it).
- Grids of 500², 1000² and 2000² cells, random obstacles (20 %) and rooms with doors,
  planned corner to corner:
  - ours: D* Lite's first plan (grid_search's numpy buckets, on the 10/14 metric with
    no corner cutting), then a replan after the robot moves three cells and finds three
    cells ahead blocked, and a re-route when a door on the path closes;
  - scipy's csgraph.dijkstra on the same graph (the same costs, checked), with the
    time to build its sparse matrix apart;
  - scikit-image's MCP_Geometric (route_through_array's search): its own metric,
    diagonals sqrt 2 long and corners cut;
  - pyastar2d's compiled A*: its own metric, every move costing 1 and corners cut.
  The peers have no incremental replan: theirs is a new search on the changed grid (the
  graph's edit not counted). Memory is tracemalloc's peak during a first plan, per cell
  of the grid; tracemalloc sees what numpy and Python allocate, not memory that a
  compiled peer allocates itself (csgraph's heap nodes, pyastar2d's arrays), so the
  peak resident memory of a fresh process is shown beside it.

Usage: python bench/planning.py [--trials N] [--sizes 500 1000 2000] [--seed S]
"""

from __future__ import annotations

import argparse
import contextlib
import os
import platform
import statistics
import subprocess
import sys
import time
import tracemalloc
from collections.abc import Callable
from functools import partial
from pathlib import Path

import networkx as nx
import numpy as np
import scipy
from scipy.sparse import csr_array
from scipy.sparse.csgraph import dijkstra

import giraff_console
from giraff_console.planning.dstar_lite import DStarLite
from giraff_console.planning.floorplan import Door, FloorPlan, Room, load_floorplan
from giraff_console.planning.grid_search import allowed_moves, moves, padded
from giraff_console.planning.room_graph import RoomGraph
from giraff_console.planning.route_planner import RoutePlanner, walls_of

EXAMPLE = Path(__file__).resolve().parents[1] / "giraff_console/floorplans/care-home.yaml"


def timed(action: Callable[[], object]) -> tuple[float, float, object]:
    """Wall and CPU milliseconds of one call, and what it returned."""
    wall, cpu = time.perf_counter(), time.process_time()
    result = action()
    return (time.perf_counter() - wall) * 1e3, (time.process_time() - cpu) * 1e3, result


def machine() -> str:
    model = platform.processor() or platform.machine()
    with contextlib.suppress(OSError), open("/proc/cpuinfo") as cpuinfo:
        for line in cpuinfo:
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    return f"{model}, {os.cpu_count()} cores"


def loadavg() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


# ---------------------------------------------------------------- room graphs


def corridor_plan(n_rooms: int) -> FloorPlan:
    """n_rooms / 16 corridors, each with 15 rooms off it (a door each, and a door
    between every third pair of neighbours), joined end to end at both ends."""
    rooms: dict[str, Room] = {}
    doors: list[Door] = []
    for i in range(n_rooms // 16):
        y = 12.0 * i
        corridor = f"corridor-{i}"
        rooms[corridor] = Room(corridor, "", (16.0, y), None, None)
        for m in range(15):
            side = 1 if m % 2 else -1
            x = 4.0 * (m // 2) + 2
            room = f"room-{i}-{m}"
            rooms[room] = Room(room, "", (x, y + 3.5 * side), None, None)
            doors.append(Door(f"door-{i}-{m}", (corridor, room), (x, y + side), 0.9, True))
            if m >= 2 and m % 3 == 0:
                neighbour = f"room-{i}-{m - 2}"
                at = (x - 2, y + 3.5 * side)
                doors.append(Door(f"door-{i}-{m}-side", (neighbour, room), at, 0.9, True))
        if i:
            for end, x in (("west", 0.0), ("east", 32.0)):
                between = (f"corridor-{i - 1}", corridor)
                doors.append(Door(f"stair-{i}-{end}", between, (x, y - 6), 1.2, True))
    return FloorPlan(f"{n_rooms} rooms", rooms, doors, None, None, Path("synthetic.yaml"))


def former_table(plan: FloorPlan, closed: set[str]) -> None:
    """What the former planner did on every door event: a networkx graph of room and
    door nodes, and Dijkstra from every room."""
    graph = nx.Graph()
    for room in plan.rooms.values():
        graph.add_node(("room", room.id), xy=room.at)
    doors_of: dict[str, list[Door]] = {room: [] for room in plan.rooms}
    for door in plan.doors:
        if door.id in closed:
            continue
        for room_id in door.between:
            at = plan.rooms[room_id].at
            graph.add_edge(
                ("door", door.id), ("room", room_id), weight=np.hypot(*np.subtract(door.at, at))
            )
            for other in doors_of[room_id]:
                length = np.hypot(*np.subtract(door.at, other.at))
                graph.add_edge(("door", door.id), ("door", other.id), weight=length)
            doors_of[room_id].append(door)
    for room_id in plan.rooms:
        nx.single_source_dijkstra(graph, ("room", room_id))


def room_graph_row(n_rooms: int, trials: int) -> list[str]:
    plan = corridor_plan(n_rooms)
    graph = RoomGraph(plan)
    names = list(plan.rooms)
    pairs = [(names[i], names[-1 - i]) for i in range(0, len(names) // 2, 3)]
    door = plan.doors[len(plan.doors) // 2].id
    events, firsts, again = [], [], []
    for trial in range(trials * 10):
        event = graph.close if trial % 2 == 0 else graph.open
        events.append(timed(partial(event, door))[0])
        route = partial(graph.route, *pairs[trial % len(pairs)])
        firsts.append(timed(route)[0])
        again.append(timed(route)[0])
    former = statistics.median(timed(partial(former_table, plan, {door}))[0] for _ in range(trials))
    # What an eager search of every route would cost on each event: csgraph's Dijkstra
    # from every room at once, on the same matrix.
    eager = partial(dijkstra, graph._matrix, indices=list(range(len(names))),
                    return_predecessors=True)  # fmt: skip
    return [
        f"{n_rooms} rooms, {len(plan.doors)} doors",
        f"{statistics.median(events) * 1e3:.0f} µs",
        f"{statistics.median(firsts):.2f} ms",
        f"{statistics.median(again) * 1e3:.1f} µs",
        f"{former:.0f} ms",
        f"{statistics.median(timed(eager)[0] for _ in range(trials)):.1f} ms",
    ]


def first_routes(trials: int) -> list[list[str]]:
    plan = load_floorplan(EXAMPLE)
    walls = walls_of(plan)
    RoutePlanner(plan, walls).between_rooms("dock", "kitchen")  # imports, caches warm
    rows = []
    for a, b in [
        ("dock", "kitchen"),
        ("room-101", "room-121"),
        ("lobby", "activity-room"),
        ("room-113", "room-114"),
        ("bathroom", "day-room"),
    ]:
        runs = []
        for _ in range(trials):
            planner = RoutePlanner(plan, walls)
            wall, cpu, path = timed(lambda p=planner, a=a, b=b: p.between_rooms(a, b))
            runs.append((wall, cpu, path))
        wall = statistics.median(r[0] for r in runs)
        cpu = statistics.median(r[1] for r in runs)
        rows.append(
            [f"{a} -> {b}", f"{wall:.1f} ms", f"{cpu:.1f} ms", f"{runs[0][2].length_m:.2f} m"]
        )
    return rows


# ---------------------------------------------------------------- grids


def random_grid(
    size: int, rng: np.random.Generator
) -> tuple[np.ndarray, list[list[tuple[int, int]]]]:
    blocked = rng.random((size, size)) < 0.2
    blocked[0, 0] = blocked[-1, -1] = False
    return blocked, []


def rooms_grid(
    size: int, rng: np.random.Generator
) -> tuple[np.ndarray, list[list[tuple[int, int]]]]:
    """Walls every size/5 cells both ways, with a door gap in each wall segment."""
    blocked = np.zeros((size, size), dtype=bool)
    step = size // 5
    doors = []
    for k in range(step, size, step):
        blocked[k, :] = True
        blocked[:, k] = True
    for k in range(step, size, step):
        for start in range(0, size, step):
            middle = start + step // 2
            for gap in (
                [(k, c) for c in range(middle - 1, middle + 2)],
                [(r, k) for r in range(middle - 1, middle + 2)],
            ):
                gap = [cell for cell in gap if 0 <= cell[0] < size and 0 <= cell[1] < size]
                for cell in gap:
                    blocked[cell] = False
                doors.append(gap)
    for k in range(step, size, step):
        for j in range(step, size, step):
            blocked[k, j] = True
    return blocked, doors


def csgraph_matrix(blocked: np.ndarray) -> csr_array:
    """Our graph as a sparse matrix: 8-connected, 10 and 14, no corner cutting."""
    grid = padded(blocked)
    width = grid.shape[1]
    mask = allowed_moves(grid)
    bits = np.unpackbits(mask[:, None], axis=1, bitorder="little")
    indptr = np.zeros(mask.size + 1, dtype=np.int64)
    np.cumsum(bits.sum(axis=1), out=indptr[1:])
    flat = np.flatnonzero(bits)
    move = flat & 7
    offsets = np.array([m[0] for m in moves(width)])
    costs = np.array([m[1] for m in moves(width)], dtype=float)
    indices = (flat >> 3) + offsets[move]
    return csr_array((costs[move], indices, indptr), shape=(mask.size, mask.size))


def csgraph_cost(matrix: csr_array, width: int, start, goal) -> float:
    index = lambda cell: (cell[0] + 1) * width + cell[1] + 1  # noqa: E731
    return float(dijkstra(matrix, indices=index(goal), min_only=True)[index(start)])


def skimage_route(blocked: np.ndarray, start, goal) -> object:
    from skimage.graph import MCP_Geometric

    costs = np.where(blocked, np.inf, 1.0)
    mcp = MCP_Geometric(costs, fully_connected=True)
    mcp.find_costs([start], [goal])
    return mcp.traceback(goal)


def pyastar_route(blocked: np.ndarray, start, goal) -> object:
    import pyastar2d

    weights = np.where(blocked, np.inf, 1.0).astype(np.float32)
    return pyastar2d.astar_path(weights, start, goal, allow_diagonal=True)


def peak_bytes(action: Callable[[], object]) -> int:
    tracemalloc.start()
    try:
        action()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def resident_peak_mb(method: str, size: int, seed: int) -> float:
    """Peak resident memory of a fresh process planning one grid, less what it held
    before the plan (the interpreter, the libraries and the grid)."""
    code = f"""
import sys; sys.path.insert(0, {str(Path(__file__).parent)!r})
import numpy as np, planning as b
blocked, _ = b.random_grid({size}, np.random.default_rng({seed}))
s, g = (0, 0), ({size - 1}, {size - 1})
def rss(key):
    for line in open('/proc/self/status'):
        if line.startswith(key): return int(line.split()[1])
import skimage.graph, pyastar2d
base = rss('VmRSS')
if {method!r} == 'ours': b.DStarLite(blocked, s, g).plan()
elif {method!r} == 'csgraph': b.csgraph_cost(b.csgraph_matrix(blocked), {size + 2}, s, g)
elif {method!r} == 'skimage': b.skimage_route(blocked, s, g)
else: b.pyastar_route(blocked, s, g)
print((rss('VmHWM') - base) / 1024)
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(out.stdout.strip())


def grid_trial(blocked: np.ndarray, doors) -> dict[str, float] | None:
    size = blocked.shape[0]
    start, goal = (0, 0), (size - 1, size - 1)
    planner = DStarLite(blocked, start, goal)
    wall, cpu, path = timed(planner.plan)
    if not isinstance(path, list) or len(path) < 10:
        return None
    result = {"ours": wall, "ours cpu": cpu}
    build, _, matrix = timed(lambda: csgraph_matrix(blocked))
    search, _, cost = timed(lambda: csgraph_cost(matrix, size + 2, start, goal))
    assert cost == planner.cost, f"csgraph {cost} != ours {planner.cost}"
    result |= {"csgraph": search, "csgraph build": build}
    result["skimage"] = timed(lambda: skimage_route(blocked, start, goal))[0]
    result["pyastar2d"] = timed(lambda: pyastar_route(blocked, start, goal))[0]
    # The robot moves three cells on, then finds three cells just ahead blocked.
    planner.move_to(path[3])
    ahead = [cell for cell in path[5:8] if cell != goal]
    changed = blocked.copy()
    for cell in ahead:
        changed[cell] = True
    planner.update_cells((cell, True) for cell in ahead)
    result["ours replan"] = timed(planner.plan)[0]
    changed_matrix = csgraph_matrix(changed)
    peers = {
        "csgraph": lambda: csgraph_cost(changed_matrix, size + 2, path[3], goal),
        "skimage": lambda: skimage_route(changed, path[3], goal),
        "pyastar2d": lambda: pyastar_route(changed, path[3], goal),
    }
    for name, action in peers.items():
        result[f"{name} replan"] = timed(action)[0]
    on_path = set(path[3:])
    closing = next((door for door in doors if on_path & set(door)), None)
    if closing is not None:
        planner.update_cells((cell, True) for cell in closing)
        result["ours door"] = timed(planner.plan)[0]
    return result


def grid_row(size: int, kind: str, trials: int, rng: np.random.Generator) -> list[str]:
    make = random_grid if kind.startswith("random") else rooms_grid
    results: list[dict[str, float]] = []
    while len(results) < trials:
        blocked, doors = make(size, rng)
        outcome = grid_trial(blocked, doors)
        if outcome is not None:
            results.append(outcome)

    def median(key: str) -> str:
        values = [r[key] for r in results if key in r]
        return f"{statistics.median(values):.1f}" if values else "-"

    start, goal = (0, 0), (size - 1, size - 1)
    ours = peak_bytes(lambda: DStarLite(blocked, start, goal).plan())
    peer = peak_bytes(lambda: csgraph_cost(csgraph_matrix(blocked), size + 2, start, goal))
    return [f"{size}² {kind}", median("ours"), median("ours cpu"), median("ours replan"),
            median("ours door"), median("csgraph build") + " + " + median("csgraph"),
            median("csgraph replan"), median("skimage"), median("skimage replan"),
            median("pyastar2d"), median("pyastar2d replan"), f"{ours / size**2:.1f}",
            f"{peer / size**2:.0f}"]  # fmt: skip


def table(header: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
    lines = [
        "| " + " | ".join(h.ljust(w) for h, w in zip(header, widths, strict=True)) + " |",
        "|" + "|".join("-" * (w + 2) for w in widths) + "|",
    ]
    lines += [
        "| " + " | ".join(str(c).rjust(w) for c, w in zip(r, widths, strict=True)) + " |"
        for r in rows
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=3, help="runs per case (default 3)")
    parser.add_argument("--sizes", type=int, nargs="+", default=[500, 1000, 2000])
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    import pyastar2d  # noqa: F401  (the bench extra: fail now rather than half way)
    import skimage

    print(
        f"giraff-console {giraff_console.__version__}, Python {platform.python_version()}, "
        f"numpy {np.__version__}, scipy {scipy.__version__}, scikit-image {skimage.__version__}"
    )
    print(f"{machine()}; load average {loadavg()} at the start")
    print("\nRoom graph (door event: close or open one door; then the first route after it)")
    print(
        table(
            [
                "plan",
                "door event",
                "first route after",
                "route again",
                "former: networkx from every room",
                "eager csgraph, every room",
            ],
            [room_graph_row(n, args.trials) for n in (32, 96, 320)],
        )
    )
    print("\nFirst route on the example care home (fresh planner, legs measured on its grid)")
    print(table(["rooms", "wall", "CPU", "length"], first_routes(args.trials)))
    print("\nGrid, corner to corner, ms (median); bytes a cell: tracemalloc peak of a first plan")
    rng = np.random.default_rng(args.seed)
    print(
        table(
            [
                "grid",
                "ours first",
                "CPU",
                "replan",
                "door closes",
                "csgraph build + search",
                "csgraph replan",
                "skimage",
                "replan",
                "pyastar2d",
                "replan",
                "ours B/cell",
                "csgraph B/cell",
            ],
            [
                grid_row(size, kind, args.trials if size <= 1000 else 1, rng)
                for size in args.sizes
                for kind in ("random 20 %", "rooms, doors")
            ],
        )
    )
    size = 1000 if 1000 in args.sizes else args.sizes[0]
    resident = {
        m: resident_peak_mb(m, size, args.seed) for m in ("ours", "csgraph", "skimage", "pyastar2d")
    }
    print(
        f"\nPeak resident memory of one {size}² first plan, bytes a cell: "
        + ", ".join(f"{m} {mb * 2**20 / size**2:.0f}" for m, mb in resident.items())
    )
    print(f"load average {loadavg()} at the end")


if __name__ == "__main__":
    main()
