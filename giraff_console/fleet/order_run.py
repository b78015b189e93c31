"""What the vehicle does with orders and instant actions (VDA 5050 2.1 §6.6-§6.9): as a
client of the robot service named FLEET, through the same `go` as every front end, and
what it keeps to say in `state` (fleet/state_report.py).

An order is checked whole before any of it runs: its shape and nodes against the plan
(fleet/orders.py), then that it starts where the robot stands, that nobody else holds
the controls, and that the way through all its released rooms is open. Then it runs as
one `go` to each released room in turn; a door node is passed with the room after it.
Unreleased nodes (the horizon) wait for an order update, which must start at the last
released node (§6.6.3 "order update").

The operator always wins (issue 28): an order is refused while a person or the program
on the virtual port holds the controls; a console that takes them, or an operator's
stop, ends the order, and the fleet reads why in `errors`.

Not thread-safe: the vehicle's own thread calls everything here (fleet/vehicle.py).
"""

from __future__ import annotations

import collections
import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

from giraff_console.fleet.orders import (
    NODE_TOLERANCE_M,
    ErrorType,
    NodeKind,
    Order,
    Refusal,
    read_order,
)
from giraff_console.fleet.state_report import ActionState, Error, OrderProgress, VehicleFacts
from giraff_console.fleet.vocabulary import ActionStatus, ErrorLevel, OperatingMode
from giraff_console.missions.docking import DOCK
from giraff_console.planning.floorplan import FloorPlan
from giraff_console.robot.loop_events import MissionChanged
from giraff_console.robot.mission import Outcome
from giraff_console.service import commands as c
from giraff_console.service.events import Controls, GoReported, RoomRenamed, ServiceEvent
from giraff_console.service.robot_service import RobotService

FLEET = "the fleet"
# What `state` keeps: the latest instant actions' states and the latest errors.
MAX_ACTIONS = 32
MAX_ERRORS = 8
# How far the robot moves before the room it stands in is judged again.
ROOM_AGAIN_M = 0.05


class OrderRun:
    """The order under way (or the last), the instant actions, and the errors."""

    def __init__(self, service: RobotService, note: Callable[[str], None]) -> None:
        self.service = service
        self.note = note
        self.order: Order | None = None
        self.progress = OrderProgress()
        self.paused = False
        self._legs: collections.deque[str] = collections.deque()  # rooms still to go to
        self._leg: str | None = None  # the room being gone to
        # Why the leg under way ends other than by arriving, when the vehicle knows first
        # (a cancel, a console that took the controls, the broker gone).
        self._ending: Error | None = None
        self._cancel: str | None = None  # the cancelOrder action waiting for the stop
        # An instant action that runs as a mission (the dock, the undock): its id, type.
        self._mission_action: tuple[str, str] | None = None
        self.actions: collections.OrderedDict[str, ActionState] = collections.OrderedDict()
        self.errors: collections.deque[Error] = collections.deque(maxlen=MAX_ERRORS)
        self._room: tuple[tuple[float, float], str | None] | None = None

    # -- what the robot service says -----------------------------------------------------

    def heard(self, event: ServiceEvent) -> None:
        if isinstance(event, GoReported):
            self._go_ended(event)
        elif isinstance(event, MissionChanged) and not event.running:
            self._mission_ended(event)
        elif isinstance(event, Controls):
            self._controls(event)
        elif isinstance(event, RoomRenamed):
            self._room = None  # the room it stands in may have a new name

    def _go_ended(self, event: GoReported) -> None:
        report = event.report
        if self._mission_action is not None and self._mission_action[1] == "startCharging":
            if report.room == DOCK:
                action_id, action_type = self._mission_action
                self._mission_action = None
                done = report.arrived
                self._act(
                    action_id,
                    action_type,
                    ActionStatus.FINISHED if done else ActionStatus.FAILED,
                    "on the dock" if done else f"{report.end.outcome.value}: {report.end.detail}",
                )
                self.service.let_go(FLEET)
            return
        if self._leg is None or report.room != self._leg:
            return
        self._leg = None
        outcome = report.end.outcome
        if outcome in (Outcome.ARRIVED, Outcome.ARRIVED_UNVERIFIED) and self._ending is None:
            if outcome is Outcome.ARRIVED_UNVERIFIED:
                # There by the estimate alone (a plan without markers, none in sight): the
                # node is reached, and the fleet is told how little that is known.
                self.errors.append(
                    Error(
                        ErrorType.MISSION,
                        ErrorLevel.WARNING,
                        f"at {report.room}, unconfirmed: {report.end.detail}",
                        self._references(),
                    )
                )
            self._reached(report.room)
            self._next_leg()
            return
        ending = self._ending or self._why_ended(report.room, report.end.outcome, report.end.detail)
        self._ending = None
        self._end_order(ending)

    def _why_ended(self, room: str, outcome: Outcome, detail: str) -> Error:
        if outcome is Outcome.STOPPED_BY_OPERATOR:
            return Error(
                ErrorType.OPERATOR,
                ErrorLevel.WARNING,
                f"an operator stopped the robot on its way to {room}",
                self._references(),
            )
        return Error(
            ErrorType.MISSION,
            ErrorLevel.WARNING,
            f"go {room}: {outcome.value}: {detail}",
            self._references(),
        )

    def _mission_ended(self, event: MissionChanged) -> None:
        if self._mission_action is None or self._mission_action[1] != "stopCharging":
            return
        action_id, action_type = self._mission_action
        self._mission_action = None
        outcome = event.end.outcome if event.end is not None else Outcome.FAILED
        done = outcome is Outcome.DONE
        self._act(
            action_id,
            action_type,
            ActionStatus.FINISHED if done else ActionStatus.FAILED,
            "off the dock" if done else outcome.value,
        )
        self.service.let_go(FLEET)

    def _controls(self, controls: Controls) -> None:
        holder = controls.holder
        if self._leg is not None and holder not in (None, FLEET) and self._ending is None:
            # Taking the controls does not end a mission by itself (a console may take
            # them to watch); from the fleet it does: the operator wins.
            self._ending = Error(
                ErrorType.OPERATOR,
                ErrorLevel.WARNING,
                f"{holder} took the controls; the order is ended",
                self._references(),
            )
            self.service.execute(c.StopMission(operator=False), FLEET)

    # -- orders ------------------------------------------------------------------------

    def take_order(self, message: dict[str, Any]) -> None:
        try:
            order = read_order(message, self._plan())
            current = self.order
            if current is not None and order.order_id == current.order_id:
                self._update(current, order)
            else:
                self._start(order)
        except Refusal as refusal:
            self._refused(refusal, message)

    def _start(self, order: Order) -> None:
        if self.active:
            assert self.order is not None
            raise Refusal(
                ErrorType.ORDER,
                f"order {self.order.order_id} is under way: cancelOrder first, or update it",
            )
        self._may_drive()
        here = self.service.room_here()
        if order.first.node_id != here:
            raise Refusal(
                ErrorType.ORDER,
                f"the order starts at {order.first.node_id}; the robot is in {here}",
                order.first.node_id,
            )
        rooms = order.rooms(order.base)
        why = self.service.why_not_through(rooms)
        if why is not None:
            raise Refusal(ErrorType.NO_ROUTE, why)
        self.errors.clear()
        self.order, self.paused = order, False
        self.progress = OrderProgress(
            order.order_id,
            order.update_id,
            order.first.node_id,
            order.first.sequence_id,
            order.nodes[1:],
            tuple((e.edge_id, e.sequence_id, e.released) for e in order.edges),
        )
        self._legs = collections.deque(rooms[1:])
        self.note(
            f"fleet: order {order.order_id} accepted: {' → '.join(rooms)}"
            + (" (more to come)" if order.horizon else "")
        )
        self._next_leg(first=True)

    def _update(self, current: Order, update: Order) -> None:
        if update.update_id < current.update_id:
            raise Refusal(
                ErrorType.ORDER_UPDATE,
                f"update {update.update_id} of order "
                f"{update.order_id} is older than "
                f"{current.update_id}",
            )
        if update.update_id == current.update_id:
            return  # sent again: the state says it is known (§6.6.3)
        if not self.active:
            raise Refusal(ErrorType.ORDER_UPDATE, f"order {current.order_id} has ended")
        end = current.base[-1]
        if (update.first.node_id, update.first.sequence_id) != (end.node_id, end.sequence_id):
            raise Refusal(
                ErrorType.ORDER_UPDATE,
                f"the update starts at {update.first.node_id} "
                f"({update.first.sequence_id}); it must "
                f"start at {end.node_id} ({end.sequence_id}), "
                "the last released node",
            )
        self._may_drive()
        rooms = [end.node_id, *update.rooms(update.base[1:])]
        why = self.service.why_not_through(rooms)
        if why is not None:
            raise Refusal(ErrorType.NO_ROUTE, why)
        kept = tuple(node for node in self.progress.nodes if node.sequence_id <= end.sequence_id)
        kept_edges = tuple(edge for edge in self.progress.edges if edge[1] < end.sequence_id)
        self.order = update
        self.progress = replace(
            self.progress,
            update_id=update.update_id,
            nodes=kept + update.nodes[1:],
            edges=kept_edges + tuple((e.edge_id, e.sequence_id, e.released) for e in update.edges),
        )
        self._legs.extend(rooms[1:])
        self.note(
            f"fleet: order {update.order_id} update {update.update_id}: on to "
            f"{' → '.join(rooms[1:]) or 'nothing more'}"
        )
        if self._leg is None:
            self._next_leg()

    def _may_drive(self) -> None:
        holder = self.service.controls().holder
        if holder not in (None, FLEET):
            raise Refusal(
                ErrorType.OPERATOR, f"{holder} holds the controls: the operator wins over the fleet"
            )

    def _next_leg(self, first: bool = False) -> None:
        while self._legs:
            room = self._legs.popleft()
            if room == self.progress.last_node:
                self._reached(room)  # a room named twice in a row: there already
                continue
            reply = self.service.execute(c.Go(room), FLEET)
            if reply.ok:
                self._leg = room
                return
            if first:
                # Nothing has run: the order is refused, not failed.
                order = self.order
                self.order, self.progress, self._legs = None, OrderProgress(), collections.deque()
                assert order is not None
                raise Refusal(ErrorType.ORDER, f"go {room}: {reply.text}", room)
            self._end_order(
                Error(
                    ErrorType.MISSION,
                    ErrorLevel.WARNING,
                    f"go {room}: {reply.text}",
                    self._references(),
                )
            )
            return
        order = self.order
        if order is not None and not order.horizon:
            self.note(f"fleet: order {order.order_id} done at {self.progress.last_node}")
        # Standing still, at the end or waiting for the horizon's release: anyone may
        # take the controls meanwhile.
        self.service.let_go(FLEET)

    def _reached(self, room: str) -> None:
        """The next room node of the order is reached: it, and the doors and edges before
        it, leave the states (§6.10.3)."""
        nodes = list(self.progress.nodes)
        index = next(
            (
                i
                for i, node in enumerate(nodes)
                if node.node_id == room and node.kind is NodeKind.ROOM
            ),
            None,
        )
        if index is None:
            return
        node = nodes[index]
        self.progress = replace(
            self.progress,
            last_node=node.node_id,
            last_sequence=node.sequence_id,
            nodes=tuple(nodes[index + 1 :]),
            edges=tuple(edge for edge in self.progress.edges if edge[1] > node.sequence_id),
        )

    def _end_order(self, error: Error) -> None:
        """The order cannot go on: said in `errors`, and nothing of it is left to do."""
        self.errors.append(error)
        self.note(f"fleet: order {self.progress.order_id} ended: {error.description}")
        self._legs.clear()
        self._leg = None
        self.paused = False
        self.progress = replace(self.progress, nodes=(), edges=())
        if self._cancel is not None:
            self._act(self._cancel, "cancelOrder", ActionStatus.FINISHED)
            self._cancel = None
        self.service.let_go(FLEET)

    @property
    def active(self) -> bool:
        """An order with something left to do: driving, or waiting for its horizon."""
        return bool(self.progress.nodes) or self._leg is not None

    def _refused(self, refusal: Refusal, message: dict[str, Any]) -> None:
        references = [("orderId", str(message.get("orderId", "")))]
        if refusal.node_id is not None:
            references.append(("nodeId", refusal.node_id))
        self.errors.append(
            Error(refusal.kind, ErrorLevel.WARNING, refusal.description, tuple(references))
        )
        self.note(f"fleet: order {message.get('orderId')} refused: {refusal}")

    def _references(self) -> tuple[tuple[str, str], ...]:
        return (("orderId", self.progress.order_id),)

    # -- instant actions ---------------------------------------------------------------

    def instant(self, action: dict[str, Any], publish_factsheet: Callable[[], None]) -> None:
        action_id, action_type = str(action["actionId"]), str(action["actionType"])
        handler = self._INSTANT.get(action_type)
        if handler is None:
            self._act(
                action_id,
                action_type,
                ActionStatus.FAILED,
                "not an action of this vehicle (its factsheet)",
            )
            self.errors.append(
                Error(
                    ErrorType.ACTION,
                    ErrorLevel.WARNING,
                    f"{action_type}: not an action of this vehicle",
                    (("actionId", action_id),),
                )
            )
            return
        if action_type == "factsheetRequest":
            publish_factsheet()
        handler(self, action_id, action_type, _parameters(action))

    def _cancel_order(self, action_id: str, action_type: str, _: dict[str, Any]) -> None:
        if not self.active:
            self._act(action_id, action_type, ActionStatus.FAILED, "no order to cancel")
            self.errors.append(
                Error(
                    ErrorType.NO_ORDER_TO_CANCEL,
                    ErrorLevel.WARNING,
                    "cancelOrder: no order under way",
                    (("actionId", action_id),),
                )
            )
            return
        self._act(action_id, action_type, ActionStatus.RUNNING)
        self._cancel = action_id
        ending = Error(
            ErrorType.ORDER, ErrorLevel.WARNING, "cancelled by the fleet", self._references()
        )
        if self._leg is None:
            self._end_order(ending)  # standing at the horizon: nothing to stop
            return
        self._ending = ending
        self.service.execute(c.StopMission(operator=False), FLEET)

    def _pause(self, action_id: str, action_type: str, _: dict[str, Any]) -> None:
        pausing = action_type == "startPause"
        reply = self.service.execute(c.Pause() if pausing else c.Resume(), FLEET)
        if reply.ok:
            self.paused = pausing
        self._act(
            action_id,
            action_type,
            ActionStatus.FINISHED if reply.ok else ActionStatus.FAILED,
            reply.text,
        )

    def _charge(self, action_id: str, action_type: str, _: dict[str, Any]) -> None:
        if self.active or self._mission_action is not None:
            self._act(
                action_id,
                action_type,
                ActionStatus.FAILED,
                "an order or another action is under way",
            )
            return
        request = c.Go(DOCK) if action_type == "startCharging" else c.Undock()
        reply = self.service.execute(request, FLEET)
        if not reply.ok:
            self._act(action_id, action_type, ActionStatus.FAILED, reply.text)
            return
        self._mission_action = (action_id, action_type)
        self._act(action_id, action_type, ActionStatus.RUNNING, reply.text)

    def _init_position(self, action_id: str, action_type: str, params: dict[str, Any]) -> None:
        plan = self._plan()
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
        map_id = params.get("mapId", plan.name)
        if room is None or map_id != plan.name:
            self._act(
                action_id,
                action_type,
                ActionStatus.FAILED,
                f"not at a room of the plan {plan.name} (lastNodeId, or x and y within "
                f"{NODE_TOLERANCE_M} m of a room's point)",
            )
            return
        heading = math.degrees(theta) if theta is not None and math.isfinite(theta) else None
        reply = self.service.execute(c.Place(room, heading), FLEET)
        self._act(
            action_id,
            action_type,
            ActionStatus.FINISHED if reply.ok else ActionStatus.FAILED,
            reply.text,
        )

    def _state_request(self, action_id: str, action_type: str, _: dict[str, Any]) -> None:
        self._act(action_id, action_type, ActionStatus.FINISHED)

    _INSTANT: dict[str, Callable[[OrderRun, str, str, dict[str, Any]], None]] = {
        "cancelOrder": _cancel_order,
        "startPause": _pause,
        "stopPause": _pause,
        "startCharging": _charge,
        "stopCharging": _charge,
        "initPosition": _init_position,
        "stateRequest": _state_request,
        "factsheetRequest": _state_request,
    }

    def _act(
        self, action_id: str, action_type: str, status: ActionStatus, result: str = ""
    ) -> None:
        self.actions[action_id] = ActionState(action_id, action_type, status, result)
        self.actions.move_to_end(action_id)
        while len(self.actions) > MAX_ACTIONS:
            self.actions.popitem(last=False)

    # -- the broker --------------------------------------------------------------------

    def broker_lost(self, stop: bool) -> None:
        """The broker went; with `stop` (fleet.on_broker_lost), the order is ended."""
        if stop and self._leg is not None and self._ending is None:
            self._ending = Error(
                ErrorType.BROKER,
                ErrorLevel.WARNING,
                "the broker went: stopped, as fleet.on_broker_lost says",
                self._references(),
            )
            self.service.execute(c.StopMission(operator=False), FLEET)
        elif stop and self.active:
            self._end_order(
                Error(
                    ErrorType.BROKER,
                    ErrorLevel.WARNING,
                    "the broker went: the order is ended, as fleet.on_broker_lost says",
                    self._references(),
                )
            )

    # -- what `state` says -------------------------------------------------------------

    def facts(self, map_id: str, extra_errors: tuple[Error, ...] = ()) -> VehicleFacts:
        service = self.service
        telemetry = service.telemetry
        holder = service.controls().holder
        state = telemetry.state if telemetry is not None else None
        driving = state is not None and (state.moving or abs(state.speed or 0.0) > 0.01)
        information: tuple[str, ...] = ()
        if self._leg is not None:
            information = (f"going to {self._leg}",)
        elif self.active:
            information = (f"waiting at {self.progress.last_node} for the order's next release",)
        return VehicleFacts(
            telemetry=telemetry,
            map_id=map_id,
            room=None if self.order is not None else self._room_here(),
            progress=self.progress,
            mode=OperatingMode.MANUAL if holder not in (None, FLEET) else OperatingMode.AUTOMATIC,
            paused=self.paused and self.active,
            driving=driving,
            errors=(*self.errors, *extra_errors),
            actions=tuple(self.actions.values()),
            information=information,
        )

    def _room_here(self) -> str | None:
        """The room the robot stands in, judged again only once it has moved: on a plan
        without outlines the judging looks along the grid to every room's point."""
        pose = self.service.control.estimate().pose
        if self._room is None or math.dist(self._room[0], (pose.x, pose.y)) > ROOM_AGAIN_M:
            self._room = ((pose.x, pose.y), self.service.room_here())
        return self._room[1]

    def _plan(self) -> FloorPlan:
        navigator = self.service.navigator
        if navigator is None:
            raise Refusal(ErrorType.ORDER, "the robot has no floor plan")
        return navigator.plan


def _parameters(action: dict[str, Any]) -> dict[str, Any]:
    return {
        str(item.get("key")): item.get("value")
        for item in action.get("actionParameters") or ()
        if isinstance(item, dict)
    }
