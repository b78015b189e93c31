"""Benchmark: the survey's pose graph (robot/pose_graph.py, issue 25 item 2) at a 30-room
building's size, beside the peers it was chosen over.

In one run, on one core (BLAS held to one thread):
- A survey of tests/robot/test_pose_graph.py's synthetic building (15 rooms a side of a
  60 m corridor, 150 markers on the walls): from the dock through every room and back,
  a full turn on the spot at the dock and, unless --no-look, at each room's middle; the
  casters turning the robot after every turn as the simulator's; the wheels and the
  camera with the EKF's noise, one id in 200 misread. The log (survey_log.py) is timed
  on its own, per poll.
- Ours: solved without walls; with the plan's walls found by the survey itself
  (survey_walls.solve_on_walls: solve, give each marker the wall only it can be on,
  solve again, until nothing changes); with each marker's wall given. Markers' error
  from the truth (p95, worst; and after the turn and shift that best fit the map onto
  the truth: its shape, apart from where its frame ended up), Gauss-Newton steps, time;
  then the parts of one solve with walls: the graph, the start (pose_graph_start.py),
  the Gauss-Newton steps (each one sparse LU), the markers' covariance (a sparse LU
  solved for their columns).
- Peers, on the same graph (walls given) from the same start:
  - Gauss-Newton with dense normal equations: one step (H = J'J made dense, numpy's
    solve), and the markers' covariance by a dense Cholesky factor solved for their
    columns; the whole solve projected at our number of steps.
  - scipy's least_squares (method "trf", tr_solver "lsmr": its only choice for a sparse
    Jacobian), the same analytic Jacobian, Cauchy's loss on the rows that may be
    outliers (a callable loss), at most 100 evaluations: time, evaluations, and the
    markers' error where it stops.

Usage: python bench/pose_graph.py [--rooms-a-side 15] [--seed 1] [--no-look] [--no-peers]
Quick: python bench/pose_graph.py --rooms-a-side 3 --no-peers
"""

from __future__ import annotations

import os

# One core, as the figure asked for is; set before numpy loads its BLAS.
for _threads in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_threads, "1")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from dataclasses import replace  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any, TypeVar  # noqa: E402

import numpy as np  # noqa: E402
import scipy  # type: ignore[import-untyped]  # noqa: E402
from scipy.linalg import cho_factor, cho_solve  # type: ignore[import-untyped]  # noqa: E402
from scipy.optimize import least_squares  # type: ignore[import-untyped]  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from giraff_console.robot import pose_graph, pose_graph_solve  # noqa: E402
from giraff_console.robot.pose_graph import Survey, SurveyResult, solve_survey  # noqa: E402
from giraff_console.robot.survey_log import SurveyLog  # noqa: E402
from giraff_console.robot.survey_walls import solve_on_walls  # noqa: E402
from tests.robot.test_pose_graph import (  # noqa: E402
    DOCK,
    WHEEL_BASE,
    Building,
    Walk,
    position_errors,
)

T = TypeVar("T")


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


def timed(run: Callable[[], T]) -> tuple[float, float, T]:
    """Wall and CPU seconds, and the result."""
    wall, cpu = time.perf_counter(), time.process_time()
    result = run()
    return time.perf_counter() - wall, time.process_time() - cpu, result


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


class Recorder:
    """Stands in for the walk's SurveyLog: passes every call on, and keeps them to
    replay into a fresh log for its own time."""

    def __init__(self, log: SurveyLog) -> None:
        self.log = log
        self.calls: list[tuple[str, tuple[Any, ...]]] = []

    def wheels(self, *args: Any, **kwargs: Any) -> None:
        self.calls.append(("wheels", (*args, kwargs.get("turned_in_place", False))))
        self.log.wheels(*args, **kwargs)

    def frame(self, sightings: Any) -> None:
        self.calls.append(("frame", (sightings,)))
        self.log.frame(sightings)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.log, name)


def replay(calls: list[tuple[str, tuple[Any, ...]]]) -> Survey:
    """The calls into a fresh log, and its survey."""
    log = SurveyLog(DOCK, WHEEL_BASE)
    for name, args in calls:
        getattr(log, name)(*args)
    return log.survey()


def p95(errors: np.ndarray) -> str:
    return f"{100 * np.percentile(errors, 95):.1f} / {100 * errors.max():.1f}"


def rigid_fit_errors(result: SurveyResult, truth: np.ndarray) -> np.ndarray:
    """Each marker's error after the turn and shift that best fit the surveyed markers
    onto the true ones (Kabsch): the map's shape, without where its frame ended up."""
    found = np.array([(m.pose.x, m.pose.y) for m in result.markers.values()])
    true = truth[list(result.markers), :2]
    a, b = found - found.mean(axis=0), true - true.mean(axis=0)
    u, _, vt = np.linalg.svd(a.T @ b)
    turn = (u @ np.diag([1.0, np.sign(np.linalg.det(u @ vt))]) @ vt).T
    return np.asarray(np.hypot(*((a @ turn.T) - b).T))


def ours(walk: Walk, survey: Survey) -> None:
    """Our three solves."""
    given = replace(survey, walls=dict(enumerate(walk.building.walls)))
    rows = []
    plan = walk.building.plan
    for name, run in (("without walls", lambda: solve_survey(survey)),
                      ("walls found in the plan", lambda: solve_on_walls(survey, plan)),
                      ("walls given", lambda: solve_survey(given))):  # fmt: skip
        wall, cpu, result = timed(run)
        held = sum(m.wall is not None and math.isfinite(m.wall.sigma_m)
                   for m in result.markers.values())  # fmt: skip
        rows.append([name, p95(position_errors(result, walk.markers)),
                     p95(rigid_fit_errors(result, walk.markers)), f"{held}",
                     f"{len(result.outliers)}", f"{result.iterations}", f"{wall:.2f}",
                     f"{cpu:.2f}"])  # fmt: skip
    print(table(["solve", "error p95 / worst, cm", "after a rigid fit", "on walls", "outliers",
                 "steps", "wall s", "CPU s"], rows))  # fmt: skip


def parts(survey: Survey) -> tuple[Any, np.ndarray, np.ndarray, int]:
    """One solve with walls given, part by part (the module's own steps, in order)."""
    rows = []
    wall, cpu, (graph, sightings) = timed(lambda: pose_graph._graph(survey))
    rows.append(["the graph", f"{1e3 * wall:.0f}", f"{1e3 * cpu:.0f}"])
    wall, cpu, start = timed(lambda: pose_graph._start(survey, graph, sightings, None))
    rows.append(["the start (headings, then positions)", f"{1e3 * wall:.0f}", f"{1e3 * cpu:.0f}"])
    active = pose_graph_solve.activity(graph, pose_graph_solve.Rejected.nothing(graph))
    wall, cpu, (x, steps, _) = timed(lambda: pose_graph_solve.gauss_newton(
        graph, start.copy(), active, pose_graph_solve.ROBUST_ITERATIONS, robust=True))  # fmt: skip
    rows.append([f"Gauss-Newton, robust: {steps} steps", f"{1e3 * wall:.0f}", f"{1e3 * cpu:.0f}"])
    active = pose_graph_solve.activity(graph, pose_graph_solve.outliers(graph, x))
    wall, cpu, (x, last, _) = timed(lambda: pose_graph_solve.gauss_newton(
        graph, x, active, pose_graph_solve.FINAL_ITERATIONS, robust=False))  # fmt: skip
    rows.append([f"Gauss-Newton, outliers out: {last} steps", f"{1e3 * wall:.0f}",
                 f"{1e3 * cpu:.0f}"])  # fmt: skip
    wall, cpu, _ = timed(lambda: pose_graph_solve.covariances(graph, x, active, 0))
    rows.append(
        ["the markers' covariance (and a keyframe's)", f"{1e3 * wall:.0f}", f"{1e3 * cpu:.0f}"]
    )
    print(table(["part", "wall ms", "CPU ms"], rows))
    return graph, start, active, steps + last


def dense_peer(graph: Any, start: np.ndarray, active: np.ndarray, steps: int) -> None:
    """One Gauss-Newton step and the markers' covariance with dense normal equations."""
    rows = []
    j = graph.jacobian(start, active)
    r = graph.residuals(start, active)

    def sparse_step() -> np.ndarray:
        normal = (j.T @ j).tocsc()
        return np.asarray(pose_graph_solve._factor(normal).solve(-(j.T @ r)))

    def dense_step() -> np.ndarray:
        normal = (j.T @ j).toarray()
        return np.asarray(np.linalg.solve(normal, -(j.T @ r)))

    wall_s, cpu_s, ours_step = timed(sparse_step)
    wall_d, cpu_d, dense = timed(dense_step)
    n = graph.size
    rows.append(["one step, sparse LU (ours)", f"{1e3 * wall_s:.0f}", f"{1e3 * cpu_s:.0f}", "-"])
    rows.append([f"one step, dense {n}x{n} ({8 * n * n / 2**20:.0f} MB)", f"{1e3 * wall_d:.0f}",
                 f"{1e3 * cpu_d:.0f}", f"{np.abs(dense - ours_step).max():.1e}"])  # fmt: skip
    p = graph.pose_size

    def dense_covariance() -> np.ndarray:
        factor = cho_factor((j.T @ j).toarray())
        columns = np.zeros((n, n - p))
        columns[p:] = np.eye(n - p)
        return np.asarray(cho_solve(factor, columns)[p:])

    wall_c, cpu_c, joint = timed(dense_covariance)
    wall_o, cpu_o, sparse = timed(lambda: pose_graph_solve.covariances(graph, start, active, 0))
    sparse_joint = sparse.markers
    rows.append(["markers' covariance, sparse (ours)", f"{1e3 * wall_o:.0f}", f"{1e3 * cpu_o:.0f}",
                 "-"])  # fmt: skip
    rows.append(["markers' covariance, dense Cholesky", f"{1e3 * wall_c:.0f}", f"{1e3 * cpu_c:.0f}",
                 f"{np.abs(joint - sparse_joint).max():.1e}"])  # fmt: skip
    rows.append([f"a solve of {steps} steps and the covariance, dense (projected)",
                 f"{1e3 * (steps * wall_d + wall_c):.0f}", f"{1e3 * (steps * cpu_d + cpu_c):.0f}",
                 "-"])  # fmt: skip
    print(table(["dense normal equations", "wall ms", "CPU ms", "largest difference"], rows))


def least_squares_peer(walk: Walk, graph: Any, start: np.ndarray, active: np.ndarray) -> None:
    """scipy's least_squares on the same graph, from the same start."""
    robust_from = graph.robust_from

    def loss(z: np.ndarray) -> np.ndarray:
        rho = np.empty((3, len(z)))
        rho[0, :robust_from], rho[1, :robust_from], rho[2, :robust_from] = z[:robust_from], 1, 0
        tail = 1 + z[robust_from:]
        rho[0, robust_from:], rho[1, robust_from:] = np.log(tail), 1 / tail
        rho[2, robust_from:] = -1 / tail**2
        return rho

    def run() -> Any:
        return least_squares(lambda x: graph.residuals(x, active), start.copy(),
                             jac=lambda x: graph.jacobian(x, active), method="trf",
                             tr_solver="lsmr", x_scale="jac", loss=loss,
                             f_scale=pose_graph_solve.ROBUST_SCALE, max_nfev=100)  # fmt: skip

    wall, cpu, solved = timed(run)
    markers = graph.split(solved.x)[2]
    truth = walk.markers[graph.marker_ids]
    errors = np.hypot(*(markers[:, :2] - truth[:, :2]).T)
    start_errors = np.hypot(*(graph.split(start)[2][:, :2] - truth[:, :2]).T)
    print(table(["least_squares trf/lsmr", "evaluations", "status", "error p95 / worst, cm",
                 "wall s", "CPU s"],
                [["from the start", "0", "-", p95(start_errors), "-", "-"],
                 ["where it stops", f"{solved.nfev}", f"{solved.status}", p95(errors),
                  f"{wall:.2f}", f"{cpu:.2f}"]]))  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rooms-a-side", type=int, default=15)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--no-look", action="store_true", help="no full turn in each room")
    parser.add_argument("--no-peers", action="store_true")
    args = parser.parse_args()
    print(f"{machine()}; Python {platform.python_version()}, numpy {np.__version__}, "
          f"scipy {scipy.__version__}; load average {loadavg()} at the start")  # fmt: skip
    building = Building(args.rooms_a_side)
    walk = Walk(building, seed=args.seed, look=not args.no_look)
    recorder = Recorder(walk.log)
    walk.log = recorder  # type: ignore[assignment]
    walk.drive()
    survey = recorder.log.survey()
    polls = sum(name == "wheels" for name, _ in recorder.calls)
    _, cpu, replayed = timed(lambda: replay(recorder.calls))
    assert len(replayed.odometry) == len(survey.odometry)
    distance = sum(math.hypot(e.motion.x, e.motion.y) for e in survey.odometry)
    print(f"\n{2 * building.rooms} rooms, {len(building.markers)} markers; a survey of "
          f"{distance:.0f} m ({distance / 0.35 / 60:.0f} min at 0.35 m/s), "
          f"{len(survey.odometry) + 1} keyframes, {len(survey.caster_turns)} turns on the "
          f"spot, {len(survey.sightings)} sightings kept of {walk.frames} frames' "
          f"({len(walk.misreads)} misread)")  # fmt: skip
    print(f"the log: {1e6 * cpu / polls:.0f} us CPU a poll (wheels and frame), "
          f"{polls} polls\n")  # fmt: skip
    ours(walk, survey)
    print()
    given = replace(survey, walls=dict(enumerate(building.walls)))
    graph, start, active, steps = parts(given)
    if not args.no_peers:
        print()
        dense_peer(graph, start, active, steps)
        print()
        least_squares_peer(walk, graph, start, active)
    print(f"\nload average {loadavg()} at the end")


if __name__ == "__main__":
    main()
