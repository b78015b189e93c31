"""What the fleet view's log says of a change: a robot that appears, one whose
connection changes, a new error in its state (a refused order is one), a message from
it that could not be used. Pure, so that tests call it directly."""

from __future__ import annotations

from giraff_console.fleet.master import Fleet, Vehicle
from giraff_console.fleet.vocabulary import ConnectionState


def news(before: Fleet, after: Fleet) -> list[str]:
    """The lines for what changed from `before` to `after`, a robot at a time."""
    lines = []
    if before.link_up != after.link_up:
        lines.append("broker connected" if after.link_up else "broker LOST: reconnecting")
    old = {vehicle.id: vehicle for vehicle in before.vehicles}
    for vehicle in after.vehicles:
        lines.extend(_vehicle_news(old.get(vehicle.id), vehicle))
    if after.ignored > before.ignored:
        lines.append(f"{after.ignored} robots beyond the view's limit are not shown")
    return lines


def _vehicle_news(before: Vehicle | None, after: Vehicle) -> list[str]:
    name, lines = after.name, []
    if before is None:
        lines.append(f"{name}: seen on the broker")
        before = Vehicle(after.id)
    if after.connection is not None and after.connection != before.connection:
        alarm = after.connection is ConnectionState.CONNECTIONBROKEN
        lines.append(f"{name}: {'CONNECTION BROKEN' if alarm else after.connection.value}")
    old_errors = set(before.state.errors) if before.state is not None else set()
    if after.state is not None:
        lines.extend(f"{name}: {error}" for error in after.state.errors if error not in old_errors)
    if after.problem is not None and after.problem != before.problem:
        lines.append(f"{name}: {after.problem}")
    return lines
