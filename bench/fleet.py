"""Benchmark: the fleet link (issue 28): 50 robots' state at 1 Hz through one broker, the
state's latency and the fleet link's CPU per robot.

One Mosquitto on 127.0.0.1 (tests/fleet/broker.py). The robots are each a runtime.Robot
(the simulator, stepped at real time, as `serve --sim` runs it) with its FleetVehicle,
built by tests/fleet/fleet_site.py in the walled wing with its markers; `--hosts`
processes host them (each its own runtimes; one process hosts several), so that no one
interpreter's lock holds more than a few robots' loops. Beside them, in processes of
their own:

- the listener, a paho client that hears every `state` and `visualization` and, in the
  driving phase, sends orders as a master control would (dock -> w-15 -> dock, again
  and again, to the first `--drive` robots);
- the peer: `--robots` bare paho clients, each with a thread that publishes the same
  JSON as a vehicle's state and visualization (headers stamped afresh, encoded each
  time) once a second: the floor for any MQTT link.

Latency is measured twice. "publish": from when the vehicle's thread handed the state to
paho (its `link.publish`, wrapped from outside in the host: the n-th state on a topic is
headerId n) to when the listener's paho callback got it, both `time.time()` on this
machine. "header": from the header's `timestamp` (milliseconds, truncated: up to 1 ms
more) to the same. Only states published inside the window count.

CPU is each thread's run time from /proc/PID/task/TID/schedstat (nanoseconds) over the
window, as a share of one core: "fleet link" is every vehicle's "fleet" thread and its
paho thread ("paho-mqtt-client-giraff.gNN"), per robot; beside it the whole host
process per robot, the control loops per robot, the peer's threads per client, and the
broker. Work done for the fleet link on other threads (the service's events queued on
the control loop's thread) is not in "fleet link".

`--busy K` runs K `python3 -c 'while 1: pass'` beside it. Every child (hosts, listener,
peer, busy loops, the broker) is in a session of its own and ended afterwards, Ctrl+C
included.

Usage: python bench/fleet.py [--robots N] [--seconds S] [--busy K] [--hosts H]
                             [--drive D]
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import itertools
import json
import os
import queue
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import paho.mqtt  # noqa: E402
import paho.mqtt.client as mqtt  # noqa: E402

from tests.fleet.broker import Broker  # noqa: E402

HZ = os.sysconf("SC_CLK_TCK")
READY_S = 180.0  # a host's robots up, on a loaded machine
STOP_S = 30.0
SETTLE_S = 5.0
NEAR = "w-15"  # 3 m from the dock (tests/fleet/test_vehicle.py)
GAP_S = 2.0


# -- in a host: robots and their vehicles ----------------------------------------------


def host(args: argparse.Namespace) -> None:
    from tests.fleet.fleet_site import FleetRobot, fleet_robots

    published: dict[str, list[float]] = {}

    def tap(each: FleetRobot) -> None:
        from giraff_console.fleet.topics import Topic

        link, topic = each.vehicle.link, each.id.topic(Topic.STATE)
        times = published.setdefault(each.id.serial_number, [])
        original = link.publish

        def publish(to: str, payload: bytes, *, retain: bool = False, qos: int = 0) -> bool:
            if to == topic:  # the n-th state is headerId n (fleet/messages.py)
                times.append(time.time())
            return original(to, payload, retain=retain, qos=qos)

        link.publish = publish  # type: ignore[method-assign, assignment]

    broker = Broker(Path(args.folder), port=args.port)
    folder = Path(args.folder) / f"host{args.first}"
    folder.mkdir()
    with fleet_robots(broker, Path(args.plan), folder, args.count, sim_speed=1.0,
                      first=args.first, before_start=tap) as robots:  # fmt: skip
        for each in robots:
            if not each.vehicle.link.wait_up(READY_S):
                raise SystemExit(f"{each.id.name} not on the broker")
        say_ready()
        sys.stdin.readline()  # "stop", or the parent gone
    Path(args.out).write_text(json.dumps(published))


def say_ready(**extra: Any) -> None:
    threads = {str(t.native_id): t.name for t in threading.enumerate()}
    print(json.dumps({"ready": True, "threads": threads, **extra}), flush=True)


# -- the listener: a master control that hears everything ------------------------------


def listen(args: argparse.Namespace) -> None:
    from giraff_console.fleet.messages import Headers, encode
    from giraff_console.fleet.topics import Topic, VehicleId

    heard: list[tuple[str, str, int, str, float]] = []
    driving: dict[str, str] = {}  # serial number -> its order under way
    orders = {"sent": 0, "done": 0}
    errors: set[str] = set()
    last: dict[str, dict[str, Any]] = {}  # the driving robots' last state, in short
    headers: dict[str, Headers] = {}
    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="bench-listener")

    def order(serial: str) -> None:
        vehicle = VehicleId("giraff", serial)
        stamp = headers.setdefault(serial, Headers(vehicle))
        order_id = f"o{orders['sent']}"
        orders["sent"] += 1
        rooms = ["dock", NEAR, "dock"]
        nodes = [{"nodeId": room, "sequenceId": 2 * i, "released": True, "actions": []}
                 for i, room in enumerate(rooms)]  # fmt: skip
        edges = [{"edgeId": f"e{i}", "sequenceId": 2 * i + 1, "released": True,
                  "startNodeId": a, "endNodeId": b, "actions": []}
                 for i, (a, b) in enumerate(itertools.pairwise(rooms))]  # fmt: skip
        body = {"orderId": order_id, "orderUpdateId": 0, "nodes": nodes, "edges": edges}
        client.publish(vehicle.topic(Topic.ORDER), encode(stamp.stamp(Topic.ORDER, body)))
        driving[serial] = order_id

    def on_message(client: mqtt.Client, userdata: object, message: mqtt.MQTTMessage) -> None:
        at = time.time()
        parts = message.topic.split("/")
        said = json.loads(message.payload)
        heard.append((parts[3], parts[4], said["headerId"], said["timestamp"], at))
        serial = parts[3]
        if parts[4] == "state" and serial in driving:
            last[serial] = {k: said[k] for k in ("orderId", "lastNodeId", "driving")}
            last[serial]["nodes"] = [n["nodeId"] for n in said["nodeStates"]]
            for error in said["errors"]:
                errors.add(f"{error['errorType']}: {error['errorDescription'][:80]}")
            if (said["orderId"] == driving[serial] and not said["nodeStates"]
                    and not said["driving"]):  # fmt: skip
                orders["done"] += 1
                order(serial)

    client.on_message = on_message
    client.connect("127.0.0.1", args.port)
    client.subscribe("uagv/v2/+/+/state")
    client.subscribe("uagv/v2/+/+/visualization")
    client.loop_start()
    say_ready()
    for line in sys.stdin:
        words = line.split()
        if words and words[0] == "drive":
            for serial in words[1:]:
                order(serial)
        else:
            break
    client.disconnect()
    client.loop_stop()
    Path(args.out).write_text(json.dumps({"heard": heard, "orders": orders,
                                          "errors": sorted(errors), "last": last}))  # fmt: skip


# -- the peer: bare paho clients publishing the same JSON at 1 Hz ----------------------


def peer(args: argparse.Namespace) -> None:
    from giraff_console.fleet.messages import encode, timestamp

    templates: dict[str, dict[str, Any]] = {}
    got = threading.Event()

    def on_template(client: mqtt.Client, userdata: object, message: mqtt.MQTTMessage) -> None:
        templates.setdefault(message.topic.rsplit("/", 1)[1], json.loads(message.payload))
        if len(templates) == 2:
            got.set()

    probe = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="bench-peer-probe")
    probe.on_message = on_template
    probe.connect("127.0.0.1", args.port)
    probe.subscribe("uagv/v2/giraff/g01/state")
    probe.subscribe("uagv/v2/giraff/g01/visualization")
    probe.loop_start()
    if not got.wait(60.0):
        raise SystemExit("no state and visualization from g01 to copy")
    probe.disconnect()
    probe.loop_stop()
    published: dict[str, list[float]] = {}
    stop = threading.Event()
    clients = []
    threads = []
    for number in range(1, args.count + 1):
        serial = f"p{number:02d}"
        client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=f"peer.{serial}")
        client.connect("127.0.0.1", args.port, keepalive=5)
        client.loop_start()
        clients.append(client)
        times = published.setdefault(serial, [])

        def run(client: mqtt.Client = client, serial: str = serial,
                times: list[float] = times) -> None:  # fmt: skip
            counter = 0
            next_at = time.monotonic()
            while not stop.wait(max(0.0, next_at - time.monotonic())):
                for kind in ("state", "visualization"):
                    message = {**templates[kind], "headerId": counter, "timestamp": timestamp(),
                               "manufacturer": "peer", "serialNumber": serial}  # fmt: skip
                    payload = encode(message)
                    if kind == "state":
                        times.append(time.time())
                    client.publish(f"uagv/v2/peer/{serial}/{kind}", payload)
                counter += 1
                next_at += 1.0

        thread = threading.Thread(target=run, name=f"peer-{serial}", daemon=True)
        threads.append(thread)
    for thread in threads:
        thread.start()
    say_ready(sizes={kind: len(encode(body)) for kind, body in templates.items()})
    sys.stdin.readline()
    stop.set()
    for thread in threads:
        thread.join(5.0)
    for client in clients:
        client.disconnect()
        client.loop_stop()
    Path(args.out).write_text(json.dumps(published))


# -- the parent ------------------------------------------------------------------------


@dataclass
class Child:
    name: str
    process: subprocess.Popen[str]
    out: Path
    threads: dict[int, str] = field(default_factory=dict)
    said: dict[str, Any] = field(default_factory=dict)
    lines: queue.Queue[str] = field(default_factory=queue.Queue)

    def read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.lines.put(line)

    def ready(self, timeout: float) -> None:
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0 or self.process.poll() is not None:
                raise RuntimeError(f"{self.name}: not ready (see its standard error)")
            try:
                line = self.lines.get(timeout=min(left, 1.0))
            except queue.Empty:
                continue
            with contextlib.suppress(ValueError):
                said = json.loads(line)
                if said.get("ready"):
                    self.said = said
                    self.threads = {int(k): v for k, v in said["threads"].items()}
                    return

    def send(self, line: str) -> None:
        assert self.process.stdin is not None
        with contextlib.suppress(OSError):
            self.process.stdin.write(line + "\n")
            self.process.stdin.flush()

    def end(self, timeout: float) -> bool:
        """Ask it to stop; killed if it has not within `timeout`. True if it stopped."""
        if self.process.poll() is None:
            self.send("stop")
            with contextlib.suppress(OSError):
                assert self.process.stdin is not None
                self.process.stdin.close()
            try:
                self.process.wait(timeout)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(5.0)
                return False
        return self.process.returncode == 0


def spawn(name: str, role: list[str], folder: Path) -> Child:
    out = folder / f"{name}.json"
    log = (folder / f"{name}.err").open("w")
    process = subprocess.Popen(
        [sys.executable, __file__, *role, "--out", str(out)],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=log, text=True,
        start_new_session=True, cwd=ROOT,
    )  # fmt: skip
    log.close()
    child = Child(name, process, out)
    threading.Thread(target=child.read, name=f"read-{name}", daemon=True).start()
    return child


def thread_ns(pid: int, tid: int) -> int:
    try:
        return int(Path(f"/proc/{pid}/task/{tid}/schedstat").read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return 0  # ended


def process_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / HZ


@dataclass
class Snapshot:
    at: float  # time.time()
    threads: dict[tuple[int, int], int]  # (pid, tid) -> ns
    processes: dict[int, float]


def snapshot(children: list[Child], broker: int) -> Snapshot:
    threads = {(c.process.pid, tid): thread_ns(c.process.pid, tid)
               for c in children for tid in c.threads}  # fmt: skip
    processes = {c.process.pid: process_s(c.process.pid) for c in children}
    processes[broker] = process_s(broker)
    return Snapshot(time.time(), threads, processes)


@dataclass
class Phase:
    name: str
    start: Snapshot
    end: Snapshot
    loads: list[str]


def cpu_share(phase: Phase, children: list[Child], which: str, startswith: str) -> float:
    """Seconds of CPU per second of the window, of the threads named `startswith...` in
    the children named `which...`."""
    total = 0
    for child in children:
        if not child.name.startswith(which):
            continue
        for tid, name in child.threads.items():
            if name.startswith(startswith):
                key = (child.process.pid, tid)
                total += phase.end.threads.get(key, 0) - phase.start.threads.get(key, 0)
    return total / 1e9 / (phase.end.at - phase.start.at)


def process_share(phase: Phase, pids: list[int]) -> float:
    used = sum(phase.end.processes[p] - phase.start.processes[p] for p in pids)
    return used / (phase.end.at - phase.start.at)


def header_time(text: str) -> float:
    return (
        datetime.datetime.strptime(text, "%Y-%m-%dT%H:%M:%S.%fZ")
        .replace(tzinfo=datetime.UTC)
        .timestamp()
    )


def percentile(values: list[float], share: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(share * len(ordered)))]


def latencies(phase: Phase, heard: list[list[Any]], published: dict[str, list[float]],
              who: str) -> dict[str, Any]:  # fmt: skip
    """States of `who` ("g": the vehicles, "p": the peer) published in the window."""
    t0, t1 = phase.start.at, phase.end.at
    received: dict[str, list[float]] = {}
    by_publish, by_header, lost = [], [], 0
    got: set[tuple[str, int]] = set()
    for serial, kind, header, stamp, at in heard:
        if kind != "state" or not serial.startswith(who):
            continue
        times = published.get(serial, [])
        if header < len(times) and t0 <= times[header] < t1:
            by_publish.append((at - times[header]) * 1000)
            by_header.append((at - header_time(stamp)) * 1000)
            received.setdefault(serial, []).append(at)
            got.add((serial, header))
    for serial, times in published.items():
        if serial.startswith(who):
            lost += sum(1 for n, t in enumerate(times) if t0 <= t < t1 and (serial, n) not in got)
    gaps = []
    for times in received.values():
        gaps += [b - a for a, b in itertools.pairwise(times)]
    seconds = t1 - t0
    return {
        "count": len(by_publish), "rate": len(by_publish) / seconds, "lost": lost,
        "robots": len(received),
        "publish": by_publish, "header": by_header,
        "max_gap": max(gaps, default=0.0), "gaps_over": sum(1 for g in gaps if g > GAP_S),
    }  # fmt: skip


def summary(name: str, figures: dict[str, Any]) -> list[str]:
    lines = []
    for how in ("publish", "header"):
        values = figures[how]
        if not values:
            lines.append(f"  {name:<9} {how:<8} nothing heard")
            continue
        lines.append(f"  {name:<9} {how:<8} p50 {statistics.median(values):6.1f}  "
                     f"p99 {percentile(values, 0.99):6.1f}  max {max(values):6.1f} ms")  # fmt: skip
    lines.append(
        f"  {name:<9} states {figures['count']} = {figures['rate']:.1f}/s from "
        f"{figures['robots']} senders, {figures['lost']} lost; longest gap "
        f"{figures['max_gap']:.2f} s, {figures['gaps_over']} gaps > {GAP_S:g} s"
    )
    return lines


def report(phase: Phase, hosts: list[Child], peer: Child | None, broker: int, robots: int,
           listened: dict[str, Any], published: dict[str, list[float]]) -> str:  # fmt: skip
    seconds = phase.end.at - phase.start.at
    fleet = cpu_share(phase, hosts, "host", "fleet")
    paho = cpu_share(phase, hosts, "host", "paho-mqtt-client-giraff.")
    loops = cpu_share(phase, hosts, "host", "control-loop")
    whole = process_share(phase, [h.process.pid for h in hosts])
    lines = [f"{phase.name}: {seconds:.1f} s window, load average {' -> '.join(phase.loads)}",
             "  CPU, % of one core per robot:",
             f"    fleet link (fleet + paho threads) {100 * (fleet + paho) / robots:6.3f}"
             f"   (fleet {100 * fleet / robots:.3f}, paho {100 * paho / robots:.3f})",
             f"    whole host process                {100 * whole / robots:6.3f}"
             f"   (control loops {100 * loops / robots:.3f})"]  # fmt: skip
    if peer is not None:
        mine = cpu_share(phase, [peer], "peer", "peer-") + cpu_share(phase, [peer], "peer", "paho")
        count = sum(1 for name in peer.threads.values() if name.startswith("peer-"))
        own = process_share(phase, [peer.process.pid])
        lines.append(
            f"    peer, bare paho at 1 Hz (threads) {100 * mine / count:6.3f}"
            f"   (its process {100 * own / count:.3f})"
        )
    broker_share = process_share(phase, [broker])
    lines.append(
        f"    broker (mosquitto, whole)         {100 * broker_share:6.3f} % of a core in all"
    )
    lines.append("  state latency, ms:")
    lines += summary("vehicles", latencies(phase, listened["heard"], published, "g"))
    if peer is not None:
        lines += summary("peer", latencies(phase, listened["heard"], published, "p"))
    return "\n".join(lines)


def machine() -> str:
    model = next((line.split(":", 1)[1].strip() for line in
                  Path("/proc/cpuinfo").read_text().splitlines()
                  if line.startswith("model name")), "?")  # fmt: skip
    version = subprocess.run(["mosquitto", "-h"], capture_output=True, text=True,
                             timeout=10).stdout.splitlines()[0]  # fmt: skip
    return (
        f"{os.cpu_count()} cores ({model}), Python {sys.version.split()[0]}, "
        f"paho-mqtt {paho.mqtt.__version__}, "
        f"{version}"
    )


def loadavg() -> str:
    return Path("/proc/loadavg").read_text().split()[0]


def window(name: str, seconds: float, children: list[Child], broker: int) -> Phase:
    start = snapshot(children, broker)
    loads = [loadavg()]
    deadline = time.monotonic() + seconds
    while (left := deadline - time.monotonic()) > 0:
        time.sleep(min(left, seconds / 4))
        loads.append(loadavg())
    return Phase(name, start, snapshot(children, broker), loads)


@contextlib.contextmanager
def busy_loops(count: int) -> Iterator[None]:
    loops = [subprocess.Popen(["python3", "-c", "while 1: pass"], start_new_session=True)
             for _ in range(count)]  # fmt: skip
    try:
        yield
    finally:
        for loop in loops:
            loop.kill()
            loop.wait(5.0)


def main(args: argparse.Namespace) -> int:
    from tests.buildings.console import put_up_markers
    from tests.buildings.walled_wing import walled_wing

    def interrupted(number: int, frame: object) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, interrupted)
    hosts_n = max(1, min(args.hosts, args.robots))
    print(f"machine: {machine()}")
    print(
        f"{args.robots} robots in {hosts_n} host processes, {args.seconds:g} s windows, "
        f"{args.busy} busy loops beside",
        flush=True,
    )
    with tempfile.TemporaryDirectory(prefix="fleet-bench-") as temp, busy_loops(args.busy):
        folder = Path(temp)
        plan = walled_wing(folder)
        put_up_markers(plan)
        broker = Broker(folder, kind="mosquitto").start()
        assert broker.process is not None
        children: list[Child] = []
        try:
            common = ["--port", str(broker.port), "--folder", str(folder)]
            listener = spawn("listener", ["--role", "listen", *common], folder)
            children.append(listener)
            listener.ready(60.0)
            hosts = []
            first = 1
            for number in range(hosts_n):
                count = args.robots // hosts_n + (number < args.robots % hosts_n)
                hosts.append(spawn(f"host{number}", ["--role", "host", *common, "--plan", str(plan),
                                                     "--first", str(first), "--count", str(count)],
                                   folder))  # fmt: skip
                first += count
            children += hosts
            for each in hosts:
                each.ready(READY_S)
            peer = None
            if not args.no_peer:
                peer = spawn("peer", ["--role", "peer", *common, "--count", str(args.robots)],
                             folder)  # fmt: skip
                children.append(peer)
                peer.ready(60.0)
                print(f"message sizes: {peer.said['sizes']} bytes", flush=True)
            time.sleep(SETTLE_S)
            phases = [window("standing", args.seconds, children, broker.process.pid)]
            if args.drive:
                serials = [f"g{n:02d}" for n in range(1, min(args.drive, args.robots) + 1)]
                listener.send("drive " + " ".join(serials))
                time.sleep(SETTLE_S)
                phases.append(window(f"{len(serials)} driving", args.seconds, children,
                                     broker.process.pid))  # fmt: skip
            ended = {c.name: c.end(STOP_S) for c in [*hosts, *([peer] if peer else [])]}
            ended[listener.name] = listener.end(STOP_S)
            failed = [name for name, ok in ended.items() if not ok]
            if failed:
                print(f"did not end cleanly: {failed} (see {folder}/*.err)")
                for name in failed:
                    err = folder / f"{name}.err"
                    print(err.read_text()[-2000:] if err.exists() else "")
                return 1
            listened = json.loads(listener.out.read_text())
            published: dict[str, list[float]] = {}
            for each in [*hosts, *([peer] if peer else [])]:
                published.update(json.loads(each.out.read_text()))
            for phase in phases:
                print(report(phase, hosts, peer, broker.process.pid, args.robots, listened,
                             published))  # fmt: skip
            if args.drive:
                orders = listened["orders"]
                print(f"orders: {orders['sent']} sent, {orders['done']} done; errors seen: "
                      f"{listened['errors'] or 'none'}")  # fmt: skip
                print(f"the driving robots' last states: {listened['last']}")
            return 0
        finally:
            for child in children:
                child.end(STOP_S if child.process.poll() is None else 0)
            broker.stop()


def parse() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robots", type=int, default=50)
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--busy", type=int, default=0, help="busy loops beside it")
    parser.add_argument("--hosts", type=int, default=5, help="processes hosting the robots")
    parser.add_argument(
        "--drive",
        type=int,
        default=10,
        help="robots driving dock -> w-15 -> dock in the second window (0: none)",
    )
    parser.add_argument("--no-peer", action="store_true")
    # The children's.
    parser.add_argument("--role", choices=("host", "listen", "peer"), help=argparse.SUPPRESS)
    parser.add_argument("--out", help=argparse.SUPPRESS)
    parser.add_argument("--port", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--folder", help=argparse.SUPPRESS)
    parser.add_argument("--plan", help=argparse.SUPPRESS)
    parser.add_argument("--first", type=int, default=1, help=argparse.SUPPRESS)
    parser.add_argument("--count", type=int, default=0, help=argparse.SUPPRESS)
    return parser.parse_args()


if __name__ == "__main__":
    arguments = parse()
    if arguments.role == "host":
        host(arguments)
    elif arguments.role == "listen":
        listen(arguments)
    elif arguments.role == "peer":
        peer(arguments)
    else:
        sys.exit(main(arguments))
