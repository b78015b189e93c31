"""Benchmark: playback timing over a long session log, and what recording costs the loop.

1. Drift: a synthetic session log (an automatic `bulk_data` poll every 50 ms of a robot
   driving, stopping and turning, with the `set p`/`set v` a console sends between them)
   is written to disk, read back with `read_log` and played on a real `ControlLoop` on
   the real clock, with no board. Every played-back exchange is stamped on arrival at
   the loop's listeners. Its lateness is the arrival time minus the time the entry was
   due: the playback's start plus its offset into the log, divided by the speed. The
   drift is the mean lateness over the last 10 s of log time minus that over the first
   10 s: the playback clock must not wander (target <= 10 ms over 10 minutes at 1x).
2. Rate: the same log at 16x, the fastest playback speed: entries per second delivered,
   and whether they still arrive on time.
3. Recording overhead: `bulk_data` exchanges (and ticks of a poll plus a `set p`) on
   the in-process simulator without pacing, so the link costs only software time, timed
   with and without a `SessionRecorder` attached as a link observer, in interleaved
   blocks of the same run; then the log is read back and its lines counted.

Usage: python bench/replay.py [--part drift|rate|overhead|all] [--minutes M] [--speed X]
                              [--count N]
"""

from __future__ import annotations

import argparse
import bisect
import gc
import os
import platform
import random
import statistics
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import giraff_console
from giraff_console.clock import RealClock
from giraff_console.link import BoardLink, Exchange, LinkError
from giraff_console.protocol.codec import Command
from giraff_console.recording.control_log import LogEntry, LogRead, format_entry, read_log
from giraff_console.recording.playback import Playback
from giraff_console.recording.session import CONTROL_LOG, RecordingSetup, SessionRecorder
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman
from giraff_console.robot.loop_events import LoopEvent, Note
from giraff_console.robot.telemetry import Telemetry
from giraff_console.robot.teleop import Teleop

POLL_S = 0.050  # the control loop's period at 20 Hz
WINDOW_S = 10.0  # log time at each end compared for the drift
DRIFT_TARGET_MS = 10.0


# -- a synthetic session log ------------------------------------------------------------


def synthetic_log(minutes: float, seed: int = 1) -> list[LogEntry]:
    """A session as the console would record it: polls every 50 ms (answered 0-2 ms
    late, as a paced 14 ms exchange is), moves of up to 0.4 m/s with their set-up and
    renewed targets, in-place turns and pauses."""
    rng = random.Random(seed)
    entries: list[LogEntry] = []
    left = right = 0.0  # wheel odometers since power-up, metres
    moved = turned = 0.0  # distance and angle of the current move
    speed, target, curve, mode = 0.0, 0.0, 0.0, 0
    phase, phase_end = "pause", 1.0
    t = 0.0
    end = minutes * 60.0
    while True:
        at = round(t + rng.uniform(0.0, 0.002), 3)
        if at > end:
            break
        if t >= phase_end:  # the next move: what a console sends before `set p`
            phase = rng.choice(("drive", "drive", "turn", "pause"))
            phase_end = t + rng.uniform(2.0, 8.0)
            moved = turned = 0.0
            if phase == "pause":
                target, curve, mode = 0.0, 0.0, 0
                entries.append(LogEntry(at + 0.016, "S", "p", "0.00000", "0"))
            else:
                target = rng.choice((0.2, 0.3, 0.4)) if phase == "drive" else 0.2
                curve = 0.0 if phase == "drive" else rng.choice((-1.0, 1.0))
                mode = 128
                entries.append(LogEntry(at + 0.016, "S", "v", f"{target:.5f}", f"{target:g}"))
                entries.append(LogEntry(at + 0.031, "S", "p", "0.28800", "0.288"))
        speed += max(-0.025, min(0.025, target - speed))  # 0.5 m/s² for 50 ms
        step = speed * POLL_S
        left += step
        right += step * (-1.0 if curve else 1.0)
        if curve:
            turned += curve * 2 * step / 0.52  # wheels 0.52 m apart
        else:
            moved += step
        entries.append(LogEntry(at, " ", "bulk_data",
                                f"cang:{turned:.5f},cdis:{moved:.5f},gvr:{speed:.5f},"
                                f"tilt_angle_from_home:0.08727,imdl:{left:.5f},"
                                f"imdr:{right:.5f},cvg:{0.0:.5f},mode:{mode},"))  # fmt: skip
        if mode and round(t / POLL_S) % 10 == 5:  # the target renewed every half second
            entries.append(LogEntry(at + 0.017, "S", "p", "0.28800", "0.288"))
        t += POLL_S
    entries.sort(key=lambda entry: entry.offset)
    return entries


def written_and_read(entries: list[LogEntry], directory: Path) -> tuple[LogRead, int]:
    path = directory / CONTROL_LOG
    path.write_text("".join(format_entry(entry) + "\n" for entry in entries), encoding="utf-8")
    log = read_log(path)
    if log.problems or len(log.entries) != len(entries):
        raise SystemExit(f"the synthetic log did not read back: {log.problems[:3]}")
    return log, path.stat().st_size


# -- playback on a real control loop ----------------------------------------------------


@dataclass
class Played:
    log: LogRead
    speed: float
    wall_s: float
    cpu_s: float
    lateness: list[float]  # seconds, per entry: arrival - due
    wake: list[float]  # of which before the tick started: tick start - due
    busy: list[float]  # of which the loop was still in an earlier tick past the due time
    offsets: list[float]  # seconds into the log
    due: list[float]  # monotonic
    gc_pauses: list[tuple[float, float, int]]  # start, end, generation


def play(log: LogRead, speed: float) -> Played:
    clock = RealClock()
    arrivals: list[tuple[float, float]] = []
    published: list[float] = []
    reports: list[str] = []
    ended = threading.Event()
    gc_pauses: list[tuple[float, float, int]] = []
    gc_began = [0.0]

    def no_board() -> BoardLink:
        raise LinkError("no board: playback only")

    def note_gc(phase: str, info: dict[str, int]) -> None:
        if phase == "start":
            gc_began[0] = time.monotonic()
        else:
            gc_pauses.append((gc_began[0], time.monotonic(), info["generation"]))

    def heard(event: LoopEvent) -> None:
        if isinstance(event, Exchange):
            # On the loop's thread, with the tick's own time as the exchange's sent_at.
            arrivals.append((time.monotonic(), event.sent_at))
        elif isinstance(event, Telemetry):
            # The last thing a tick does: when the loop goes back to waiting.
            published.append(time.monotonic())
        elif isinstance(event, Note):
            reports.append(event.text)

    control = ControlLoop(no_board, teleop=Teleop(), deadman=Deadman(clock), clock=clock)
    control.subscribe(heard)
    control.start()
    time.sleep(0.2)  # past the first connection attempt
    gc.callbacks.append(note_gc)
    cpu = time.process_time()
    start = clock.now()
    control.play(Playback("synthetic", log, start, speed), ended.set)
    duration = (log.entries[-1].offset - log.entries[0].offset) / speed
    if not ended.wait(duration + 30.0):
        raise SystemExit(f"playback did not finish; the loop said: {reports[-5:]}")
    wall, cpu = clock.now() - start, time.process_time() - cpu
    gc.callbacks.remove(note_gc)
    control.stop()
    if len(arrivals) != len(log.entries):
        raise SystemExit(f"{len(arrivals)} exchanges played for {len(log.entries)} entries")
    first = log.entries[0].offset
    due = [start + (entry.offset - first) / speed for entry in log.entries]
    busy = []
    for (_, tick), at in zip(arrivals, due, strict=True):
        # The end of the tick before this one; after the due time, the loop was busy.
        index = bisect.bisect_left(published, tick) - 1
        busy.append(max(0.0, min(published[index], tick) - at) if index >= 0 else 0.0)
    return Played(
        log, speed, wall, cpu,
        lateness=[arrived - at for (arrived, _), at in zip(arrivals, due, strict=True)],
        wake=[tick - at for (_, tick), at in zip(arrivals, due, strict=True)],
        busy=busy,
        offsets=[entry.offset - first for entry in log.entries],
        due=due,
        gc_pauses=gc_pauses,
    )  # fmt: skip


def percentile(values: list[float], share: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(share * (len(ordered) - 1)))]


def stats_row(name: str, seconds: list[float]) -> str:
    ms = [s * 1e3 for s in seconds]
    return (f"  {name:<30}{statistics.mean(ms):>8.3f}{percentile(ms, 0.5):>8.3f}"
            f"{percentile(ms, 0.95):>8.3f}{percentile(ms, 0.99):>8.3f}{max(ms):>8.3f}")  # fmt: skip


def report_playback(played: Played, size: int) -> None:
    entries = played.log.entries
    polls = sum(entry.frame_marker for entry in entries)
    span = played.offsets[-1]
    print(f"  log: {span / 60:.1f} min, {len(entries)} entries ({polls} bulk_data polls, "
          f"{len(entries) - polls} sets), {size / 1e6:.2f} MB, "
          f"read back with read_log")  # fmt: skip
    print(f"  played at {played.speed:g}x in {played.wall_s:.2f} s wall (log time / speed: "
          f"{span / played.speed:.2f} s); "
          f"{played.cpu_s / played.wall_s:.1%} of one core")  # fmt: skip
    print(f"  {'lateness, ms':<30}{'mean':>8}{'p50':>8}{'p95':>8}{'p99':>8}{'max':>8}")
    print(stats_row("arrival - due", played.lateness))
    print(stats_row("  tick start - due (wake-up)", played.wake))
    print(stats_row("    of which loop busy past due", played.busy))
    # Includes handing out the entries due before it in the same tick.
    in_tick = [total - wake for total, wake in zip(played.lateness, played.wake, strict=True)]
    print(stats_row("  arrival - tick start", in_tick))
    report_late(played)
    head = [ms for at, ms in zip(played.offsets, played.lateness, strict=True) if at < WINDOW_S]
    tail = [ms for at, ms in zip(played.offsets, played.lateness, strict=True)
            if at > span - WINDOW_S]  # fmt: skip
    drift = (statistics.mean(tail) - statistics.mean(head)) * 1e3
    minutes = [at / 60 for at in played.offsets]
    slope = statistics.linear_regression(minutes, played.lateness).slope * 1e3
    print(f"  mean lateness over the first {WINDOW_S:g} s of log time "
          f"{statistics.mean(head) * 1e3:.3f} ms, over the last {WINDOW_S:g} s "
          f"{statistics.mean(tail) * 1e3:.3f} ms")  # fmt: skip
    verdict = "within" if abs(drift) <= DRIFT_TARGET_MS else "OVER"
    print(f"  drift {drift:+.3f} ms over {span / 60:.1f} min of log ({verdict} the "
          f"{DRIFT_TARGET_MS:g} ms target); trend {slope * 10:+.4f} ms per 10 min "
          f"(least squares)")  # fmt: skip


def report_late(played: Played, threshold: float = 0.001) -> None:
    """Where the time went for the entries more than `threshold` late."""
    late = [i for i, lateness in enumerate(played.lateness) if lateness > threshold]
    in_gc = busy = 0
    for i in late:
        arrival = played.due[i] + played.lateness[i]
        if any(began < arrival and end > played.due[i] for began, end, _ in played.gc_pauses):
            in_gc += 1
        elif played.busy[i] > played.lateness[i] / 2:
            busy += 1
    pauses = [(end - began) * 1e3 for began, end, _ in played.gc_pauses]
    over_10 = sum(lateness > DRIFT_TARGET_MS / 1e3 for lateness in played.lateness)
    print(f"  late by > {threshold * 1e3:g} ms: {len(late)} of {len(played.lateness)} entries "
          f"(> {DRIFT_TARGET_MS:g} ms: {over_10}); of those {in_gc} overlap a GC pause, "
          f"{busy} mostly the loop busy in an earlier tick, {len(late) - in_gc - busy} "
          f"mostly waking late from the wait (OS scheduling)")  # fmt: skip
    if pauses:
        print(f"  GC during playback: {len(pauses)} collections "
              f"({sum(g == 2 for _, _, g in played.gc_pauses)} of generation 2), "
              f"longest {max(pauses):.2f} ms")  # fmt: skip


def drift(minutes: float, speed: float) -> None:
    with tempfile.TemporaryDirectory() as scratch:
        log, size = written_and_read(synthetic_log(minutes), Path(scratch))
    print(f"drift: playback on a ControlLoop (RealClock, 20 Hz, no board) at {speed:g}x")
    report_playback(play(log, speed), size)


def rate(minutes: float, speed: float) -> None:
    with tempfile.TemporaryDirectory() as scratch:
        log, size = written_and_read(synthetic_log(minutes), Path(scratch))
    print(f"rate: the same log at {speed:g}x")
    played = play(log, speed)
    report_playback(played, size)
    span = played.offsets[-1]
    due = [at / speed for at in played.offsets]
    arrived = [at + late for at, late in zip(due, played.lateness, strict=True)]
    delivered = (len(arrived) - 1) / (arrived[-1] - arrived[0])
    logged = (len(arrived) - 1) / span * speed
    worst = max(played.lateness) * 1e3
    p99 = percentile(played.lateness, 0.99) * 1e3
    gap = POLL_S / speed * 1e3
    kept_up = delivered >= 0.999 * logged and p99 < gap
    print(f"  delivered {delivered:.1f} entries/s, the log at {speed:g}x asks for {logged:.1f}: "
          f"{'kept up' if kept_up else 'FELL BEHIND'} (p99 lateness {p99:.3f} ms, max "
          f"{worst:.2f} ms; polls {gap:.3f} ms apart)")  # fmt: skip


# -- recording overhead ---------------------------------------------------------------


def overhead(count: int, block: int = 500) -> None:
    """Exchanges timed with recording off and on, in interleaved blocks of `block`."""
    link = BoardLink.open("giraff-sim://")
    with tempfile.TemporaryDirectory() as scratch:
        errors: list[str] = []
        recorder = SessionRecorder(Path(scratch), RecordingSetup(port="giraff-sim://"),
                                   time.monotonic, errors.append)  # fmt: skip
        mode = "off"
        observer_s: list[float] = []

        def gate(exchange: Exchange) -> None:
            # The same observer in every mode, so that only the recorder differs.
            if mode == "on":
                recorder.exchange(exchange)
            elif mode == "timed":
                began = time.perf_counter()
                recorder.exchange(exchange)
                observer_s.append(time.perf_counter() - began)

        link.add_observer(gate)
        set_p = (Command("set", "p", 0.288), Command("set", "p", 0.2))
        counter = 0

        def bulk() -> None:
            link.bulk(automatic=True)

        def tick() -> None:
            nonlocal counter
            link.bulk(automatic=True)
            link.send(set_p[counter % 2])
            counter += 1

        results: dict[str, dict[str, list[float]]] = {}
        observer: dict[str, list[float]] = {}
        recorded = 0
        for name, work, exchanges in (("bulk_data", bulk, 1), ("bulk_data + set p", tick, 2)):
            for _ in range(200):  # warm up
                work()
            timings: dict[str, list[float]] = {"off": [], "on": [], "timed": []}
            observer_s = []
            while len(timings["off"]) < count:
                for mode in ("off", "on", "timed"):
                    n = min(block, count - len(timings[mode]))
                    times = timings[mode]
                    for _ in range(n):
                        began = time.perf_counter()
                        work()
                        times.append(time.perf_counter() - began)
                    if mode != "off":
                        recorded += n * exchanges
            mode = "off"
            results[name] = timings
            observer[name] = observer_s
        closing = time.perf_counter()
        summary = recorder.close()
        closing = time.perf_counter() - closing
        log_path = recorder.path / CONTROL_LOG
        with log_path.open("rb") as file:
            lines = sum(1 for _ in file)
        read = read_log(log_path)
    link.close()

    print(f"overhead: in-process simulator (no pacing), {count} per mode, interleaved "
          f"blocks of {block}")  # fmt: skip
    print(f"  {'per exchange or tick, us':<34}{'mean':>8}{'p95':>8}")
    for name, timings in results.items():
        unit = "exchange" if name == "bulk_data" else "tick"
        off, on = [t * 1e6 for t in timings["off"]], [t * 1e6 for t in timings["on"]]
        print(f"  {name + ', no recorder':<34}{statistics.mean(off):>8.1f}"
              f"{percentile(off, 0.95):>8.1f}")  # fmt: skip
        print(f"  {name + ', recording':<34}{statistics.mean(on):>8.1f}"
              f"{percentile(on, 0.95):>8.1f}")  # fmt: skip
        mean_cost = statistics.mean(on) - statistics.mean(off)
        p95_cost = percentile(on, 0.95) - percentile(off, 0.95)
        print(f"  {'  overhead':<34}{mean_cost:>+8.1f}{p95_cost:>+8.1f}   per {unit}: "
              f"{mean_cost / (POLL_S * 1e6):+.3%} of a 50 ms period (mean), "
              f"{p95_cost / (POLL_S * 1e6):+.3%} (p95)")  # fmt: skip
        calls = [t * 1e6 for t in observer[name]]
        print(f"  {'  observer call (format + queue)':<34}{statistics.mean(calls):>8.1f}"
              f"{percentile(calls, 0.95):>8.1f}   per exchange, {len(calls)} calls")  # fmt: skip
    ok = lines == recorded == len(read.entries) and not read.problems and not errors
    print(f"  log file: {lines} lines, {recorded} exchanges recorded, {len(read.entries)} "
          f"entries read back, {len(read.problems)} problems: {'ok' if ok else 'MISMATCH'} "
          f"({summary}; close took {closing * 1e3:.1f} ms)")  # fmt: skip
    if errors:
        print(f"  recorder errors: {errors}")


# -- main -------------------------------------------------------------------------------


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--part", choices=("drift", "rate", "overhead", "all"), default="all")
    parser.add_argument("--minutes", type=float, default=10.0, help="of synthetic log")
    parser.add_argument("--speed", type=float, help="playback speed (drift: 1, rate: 16)")
    parser.add_argument("--count", type=int, default=10000,
                        help="overhead: exchanges (or ticks) per mode")  # fmt: skip
    args = parser.parse_args()
    if args.minutes * 60 < 2 * WINDOW_S:
        parser.error(f"--minutes must cover two {WINDOW_S:g} s windows")
    print(f"giraff-console {giraff_console.__version__}, Python {platform.python_version()}, "
          f"{platform.machine()}, {cpu_model()}, {os.cpu_count()} cores")  # fmt: skip
    if args.part in ("drift", "all"):
        drift(args.minutes, args.speed or 1.0)
    if args.part in ("rate", "all"):
        rate(args.minutes, args.speed or 16.0)
    if args.part in ("overhead", "all"):
        overhead(args.count)


if __name__ == "__main__":
    main()
