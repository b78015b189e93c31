"""Benchmark: bad input for a vehicle (issue 28, "5. Bad input"; Done-when: "10,000
malformed or hostile MQTT messages per topic kind: 0 crashes, 0 motion").

One simulated robot (the walled wing, at its dock) as a VDA 5050 vehicle on a Mosquitto
of its own; 10,000 hostile messages (tests/fleet/hostile.py, seed 28) on each of its
topics: `order` and `instantActions` (which it reads) paced in bursts of 32, below its
inbox of 64, so that most are read; `state`, `connection`, `factsheet` and
`visualization` (its own, by an impostor: never read); then one pure flood of 10,000
instant actions at once. For each: messages read per second, refused, dropped (inbox
full, or over the link's size), the vehicle's internal errors (an exception its thread
caught), crashes (its thread dead), missions started and the true pose's motion, the
largest state and the longest gap between states. Then a good order, which must still
reach a room 3 m away.

Usage: python bench/fleet_hostile.py [--count N] [--seed S]
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from giraff_console.fleet.topics import Topic
from giraff_console.planning.floorplan import load_floorplan
from tests.buildings.console import put_up_markers
from tests.buildings.walled_wing import walled_wing
from tests.fleet.broker import Broker
from tests.fleet.fleet_site import Watcher, fleet_robots
from tests.fleet.hostile import IMPOSTOR_KINDS, READ_KINDS, SEED, Site, hostile_messages
from tests.fleet.pelting import Pelting

NEAR = "w-15"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=10_000)
    parser.add_argument("--seed", type=int, default=SEED)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="fleet-hostile-"))
    plan_path = walled_wing(folder)
    put_up_markers(plan_path)
    plan = load_floorplan(plan_path)
    broker = Broker(folder).start()
    failures = 0
    try:
        with fleet_robots(broker, plan_path, folder, 1) as robots:
            robot = robots[0]
            while not (robot.vehicle._connection and robot.robot.service.room_here() == "dock"):
                time.sleep(0.05)
            pelting = Pelting(robot, broker.port)
            site = Site(robot.id, plan, "dock")
            runs = [(kind.value, kind, 32, kind in READ_KINDS)
                    for kind in (*READ_KINDS, *IMPOSTOR_KINDS)]  # fmt: skip
            runs.append(("flood", Topic.INSTANT_ACTIONS, 0, True))
            print(f"{args.count} messages per kind, seed {args.seed}")
            for name, kind, burst, read in runs:
                seed = args.seed + (1 if name == "flood" else 0)
                messages = hostile_messages(site, kind, args.count, seed)
                figures = pelting.send(name, messages, burst=burst, read=read)
                crashed = not robot.vehicle._thread.is_alive()
                print(figures.line(), "| crashed" if crashed else "| alive", flush=True)
                failures += crashed or figures.missions > 0 or figures.moved_m >= 0.001
            watcher = Watcher(broker, "bench-after")
            watcher.order(robot.id, "good", ["dock", NEAR])
            started = time.monotonic()
            try:
                watcher.wait(
                    lambda: (
                        (pose := robot.robot.true_pose()) is not None
                        and math.dist((pose.x, pose.y), plan.rooms[NEAR].at) <= 0.10
                    ),
                    60,
                )
                print(f"a good order afterwards: {NEAR} reached in "
                      f"{time.monotonic() - started:.1f} s")  # fmt: skip
            except AssertionError as error:
                print(f"a good order afterwards: FAILED ({error})")
                failures += 1
            finally:
                watcher.close()
            pelting.close()
    finally:
        broker.stop()
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
