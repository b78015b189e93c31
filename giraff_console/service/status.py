"""How things stand, said once for every front end (issue 26): the console's `status`
command, `giraff-console status` and its `--json`.

From a `Situation` (service/events.py): where the robot is and how well that is known,
the mission under way with the distance left and its ETA, the battery, the link to the
board, who holds the controls, the last mission's end. `status_json` is a documented,
stable schema (docs/daemon.md, "status --json"): keys are added, never renamed or
removed, and `schema` says which version a script reads.
"""

from __future__ import annotations

import math
from typing import Any

from giraff_console.robot.battery import Battery
from giraff_console.robot.mission import Progress
from giraff_console.robot.telemetry import LinkState, Telemetry
from giraff_console.service.events import Situation

SCHEMA = 1


def status_lines(situation: Situation, consoles: tuple[str, ...]) -> tuple[str, ...]:
    """What the operator reads, a line for each part."""
    telemetry = situation.telemetry
    lines = [
        f"link: {_link(telemetry)}",
        f"pose: {_pose(telemetry)}",
        f"mission: {_mission(situation, telemetry)}",
        f"battery: {_battery(telemetry.battery if telemetry else None)}",
        f"camera: {_camera(situation.camera_fps)}",
        f"controls: {situation.holder or 'free'}; consoles: {', '.join(consoles) or 'none'}",
    ]
    last = situation.last_mission
    ended = f"{last.name}: {last.end.words}" if last is not None and last.end else "none"
    lines.append(f"last mission: {ended}")
    if situation.recording or situation.playing:
        lines.append("recording" if situation.recording else "playing back")
    return tuple(lines)


def status_json(situation: Situation, consoles: tuple[str, ...]) -> dict[str, Any]:
    """The same as data (schema SCHEMA)."""
    telemetry = situation.telemetry
    last = situation.last_mission
    return {
        "schema": SCHEMA,
        "link": telemetry.link.value if telemetry is not None else None,
        "pose": _pose_json(telemetry),
        "mission": _mission_json(situation, telemetry),
        "battery": _battery_json(telemetry.battery if telemetry else None),
        "holder": situation.holder,
        "consoles": list(consoles),
        "last_mission": None if last is None or last.end is None else {
            "name": last.name, "outcome": last.end.outcome.value, "why": last.end.why,
            "detail": last.end.detail,
        },
        "recording": situation.recording,
        "playing": situation.playing,
        "camera_fps": _rounded(situation.camera_fps),
    }  # fmt: skip


def _link(telemetry: Telemetry | None) -> str:
    if telemetry is None:
        return "not yet heard from the control loop"
    if telemetry.link is LinkState.LOST:
        return "LOST: the board does not answer; reconnecting"
    return f"connected, control loop at {telemetry.loop_hz:.0f} Hz"


def _pose(telemetry: Telemetry | None) -> str:
    if telemetry is None:
        return "unknown"
    pose, estimate = telemetry.pose, telemetry.estimate
    text = f"x={pose.x:.2f} y={pose.y:.2f} m, heading {math.degrees(pose.heading) % 360:.1f}°"
    if estimate is None:
        return text + " (odometry)"
    sigma = f"± {estimate.sigma_m:.2f} m, ± {math.degrees(estimate.sigma_heading):.1f}°"
    return f"{text} {sigma}; {estimate.basis.value}, {estimate.since_fix_m:.1f} m since a fix"


def _pose_json(telemetry: Telemetry | None) -> dict[str, Any] | None:
    if telemetry is None:
        return None
    pose, estimate = telemetry.pose, telemetry.estimate
    return {
        "x": round(pose.x, 4), "y": round(pose.y, 4),
        "heading_deg": round(math.degrees(pose.heading) % 360, 3),
        "sigma_m": round(estimate.sigma_m, 4) if estimate else None,
        "sigma_heading_deg": round(math.degrees(estimate.sigma_heading), 3) if estimate else None,
        "basis": estimate.basis.value if estimate else None,
        "since_fix_m": round(estimate.since_fix_m, 3) if estimate else None,
    }  # fmt: skip


def _mission(situation: Situation, telemetry: Telemetry | None) -> str:
    progress = telemetry.mission if telemetry is not None else None
    if progress is not None:
        return progress.line()
    return situation.mission or "none"


def _mission_json(situation: Situation, telemetry: Telemetry | None) -> dict[str, Any] | None:
    progress: Progress | None = telemetry.mission if telemetry is not None else None
    if situation.mission is None and progress is None:
        return None
    return {
        "name": progress.name if progress else situation.mission,
        "state": progress.state if progress else None,
        "left_m": _rounded(progress.left_m) if progress else None,
        "total_m": _rounded(progress.total_m) if progress else None,
        "eta_s": _rounded(progress.eta_s) if progress else None,
        "line": progress.line() if progress else None,
    }


def _battery(battery: Battery | None) -> str:
    if battery is None:
        return "unknown (this board does not say)"
    percent = f"{battery.percent:.0f}%" if battery.percent is not None else "?%"
    volts = f", {battery.voltage:.1f} V" if battery.voltage is not None else ""
    return f"{percent}{volts}, {battery.status.name.lower().replace('_', ' ')}"


def _battery_json(battery: Battery | None) -> dict[str, Any] | None:
    if battery is None:
        return None
    return {"percent": _rounded(battery.percent), "volts": _rounded(battery.voltage),
            "charging": battery.charging, "status": battery.status.name.lower()}  # fmt: skip


def _camera(fps: float | None) -> str:
    if fps is None:
        return "none"
    return f"{fps:.0f} fps" if fps else "idle (nothing is looking through it)"


def _rounded(value: float | None) -> float | None:
    return None if value is None else round(value, 3)
