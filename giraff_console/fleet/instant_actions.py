"""The instant actions a Giraff takes from the fleet (VDA 5050 2.1 §6.8), beside its
order (fleet/order_run.py), each with its state in `state.actionStates`.

Charging is the dock's: an order that ends in the plan's start room drives onto the
dock, and the robot charges there (a board that reports its charger says so). So
`startCharging` does not drive: it is FINISHED on the dock while the charger charges,
and FAILED elsewhere, with what to send instead; a drive across the building is an
order, which the fleet manager's traffic control can see. `stopCharging` backs off the
dock (the undock, `undock_distance`), a move that a console's take of the controls or a
`cancelOrder` stops as it stops an order.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from giraff_console.fleet.order_run import FLEET, OrderRun
from giraff_console.fleet.orders import NODE_TOLERANCE_M, ErrorType
from giraff_console.fleet.state_report import Error
from giraff_console.fleet.vocabulary import ActionStatus, ActionType, ErrorLevel
from giraff_console.robot.battery import Battery
from giraff_console.robot.loop_events import MissionChanged
from giraff_console.robot.mission import Outcome
from giraff_console.service import commands as c
from giraff_console.service.events import Reply, ServiceEvent


class InstantActions:
    """Takes each instant action, on the vehicle's thread."""

    def __init__(self, run: OrderRun, publish_factsheet: Callable[[], None]) -> None:
        self.run = run
        self.service = run.service
        self.publish_factsheet = publish_factsheet

    def take(self, action: dict[str, Any]) -> None:
        action_id, action_type = str(action["actionId"]), str(action["actionType"])
        try:
            kind = ActionType(action_type)
        except ValueError:
            self._failed(action_id, action_type, "not an action of this vehicle (its factsheet)")
            return
        try:
            _TAKE[kind](self, action_id, kind, _parameters(action))
        finally:
            if not self.run.driving:
                # Standing still: whatever the fleet asked, anyone may take the controls.
                self.service.let_go(FLEET)

    def heard(self, event: ServiceEvent) -> None:
        """The undock's end: nobody else starts a mission while the fleet holds the
        controls, and a take of them ends it (the service)."""
        if isinstance(event, MissionChanged) and not event.running and self.run.undocking:
            action_id, self.run.undocking = self.run.undocking, None
            outcome = event.end.outcome if event.end is not None else Outcome.FAILED
            done = outcome is Outcome.DONE
            self.run.act(
                action_id,
                ActionType.STOP_CHARGING.value,
                ActionStatus.FINISHED if done else ActionStatus.FAILED,
                "off the dock" if done else outcome.value,
            )
            self.service.let_go(FLEET)

    def _failed(self, action_id: str, action_type: str, why: str) -> None:
        self.run.act(action_id, action_type, ActionStatus.FAILED, why)
        self.run.warn(
            Error(
                ErrorType.ACTION,
                ErrorLevel.WARNING,
                f"{action_type}: {why}",
                (("actionId", action_id),),
            )
        )

    def _replied(self, action_id: str, kind: ActionType, reply: Reply) -> None:
        """Done or not, as the service's reply to what the action asked says."""
        status = ActionStatus.FINISHED if reply.ok else ActionStatus.FAILED
        self.run.act(action_id, kind.value, status, reply.text)

    def _battery(self) -> Battery | None:
        telemetry = self.service.telemetry
        return telemetry.battery if telemetry is not None else None

    def _cancel_order(self, action_id: str, kind: ActionType, _: dict[str, Any]) -> None:
        if self.run.cancel(action_id):
            self.run.act(action_id, kind.value, ActionStatus.RUNNING)
            return
        if self.run.undocking is not None:
            self.service.execute(c.StopMission(operator=False), FLEET)
            self.run.act(action_id, kind.value, ActionStatus.FINISHED, "the undock is stopped")
            return
        self.run.act(action_id, kind.value, ActionStatus.FAILED, "no order to cancel")
        self.run.warn(
            Error(
                ErrorType.NO_ORDER_TO_CANCEL,
                ErrorLevel.WARNING,
                "cancelOrder: no order under way",
                (("actionId", action_id),),
            )
        )

    def _pause(self, action_id: str, kind: ActionType, _: dict[str, Any]) -> None:
        if not self.run.driving:
            # Only what the fleet itself runs: an operator's mission is the operator's.
            self._failed(action_id, kind.value, "no order of the fleet's under way")
            return
        pausing = kind is ActionType.START_PAUSE
        reply = self.service.execute(c.Pause() if pausing else c.Resume(), FLEET)
        if reply.ok:
            self.run.paused = pausing
        self._replied(action_id, kind, reply)

    def _start_charging(self, action_id: str, kind: ActionType, _: dict[str, Any]) -> None:
        battery = self._battery()
        if battery is None:
            self._failed(action_id, kind.value, "this board does not report its charger")
        elif battery.charging:
            self.run.act(action_id, kind.value, ActionStatus.FINISHED, "charging on the dock")
        else:
            dock = self.run.plan().start
            self._failed(
                action_id,
                kind.value,
                f"not on the dock: an order that ends at {dock} "
                "drives onto it, and the robot charges there",
            )

    def _stop_charging(self, action_id: str, kind: ActionType, _: dict[str, Any]) -> None:
        battery = self._battery()
        refusal = self.run.may_drive()
        if self.run.driving or self.run.active:
            self._failed(action_id, kind.value, "an order is under way")
        elif battery is None or not battery.charging:
            self._failed(action_id, kind.value, "not charging on the dock")
        elif refusal is not None:
            self._failed(action_id, kind.value, refusal.description)
        else:
            reply = self.service.execute(c.Undock(), FLEET)
            if not reply.ok:
                self._failed(action_id, kind.value, reply.text)
                return
            self.run.undocking = action_id
            self.run.act(action_id, kind.value, ActionStatus.RUNNING, reply.text)

    def _init_position(self, action_id: str, kind: ActionType, params: dict[str, Any]) -> None:
        plan = self.run.plan()
        room = params.get("lastNodeId")
        try:
            x, y = float(params.get("x", math.nan)), float(params.get("y", math.nan))
            theta = float(params["theta"]) if "theta" in params else None
        except (TypeError, ValueError, OverflowError):
            x = y = math.nan
            theta = None
        if not isinstance(room, str) or room not in plan.rooms:
            room = next(
                (
                    name
                    for name, r in plan.rooms.items()
                    if math.dist(r.at, (x, y)) <= NODE_TOLERANCE_M
                ),
                None,
            )
        if room is None or params.get("mapId", plan.name) != plan.name:
            self._failed(
                action_id,
                kind.value,
                f"not at a room of the plan {plan.name} "
                "(lastNodeId, or x and y within "
                f"{NODE_TOLERANCE_M} m of a room's point)",
            )
            return
        refusal = self.run.may_drive()
        if refusal is not None:
            self._failed(action_id, kind.value, refusal.description)
            return
        heading = math.degrees(theta) if theta is not None and math.isfinite(theta) else None
        reply = self.service.execute(c.Place(room, heading), FLEET)
        self._replied(action_id, kind, reply)

    def _state_request(self, action_id: str, kind: ActionType, _: dict[str, Any]) -> None:
        if kind is ActionType.FACTSHEET_REQUEST:
            self.publish_factsheet()
        self.run.act(action_id, kind.value, ActionStatus.FINISHED)


_TAKE: dict[ActionType, Callable[[InstantActions, str, ActionType, dict[str, Any]], None]] = {
    ActionType.CANCEL_ORDER: InstantActions._cancel_order,
    ActionType.START_PAUSE: InstantActions._pause,
    ActionType.STOP_PAUSE: InstantActions._pause,
    ActionType.START_CHARGING: InstantActions._start_charging,
    ActionType.STOP_CHARGING: InstantActions._stop_charging,
    ActionType.INIT_POSITION: InstantActions._init_position,
    ActionType.STATE_REQUEST: InstantActions._state_request,
    ActionType.FACTSHEET_REQUEST: InstantActions._state_request,
}


def _parameters(action: dict[str, Any]) -> dict[str, Any]:
    return {
        str(item.get("key")): item.get("value")
        for item in action.get("actionParameters") or ()
        if isinstance(item, dict)
    }
