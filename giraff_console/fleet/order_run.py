"""What the vehicle does with orders (VDA 5050 2.1 §6.6-§6.7): as a client of the robot
service named FLEET, through the same `go` as every front end, and what it keeps to say
in `state` (fleet/state_report.py). The instant actions are fleet/instant_actions.py's.

An order is checked whole before any of it runs: its shape and nodes against the plan
(fleet/orders.py), then that it starts where the robot stands, that nobody else holds
the controls and no operator's stop holds the fleet, and that the way through all its
released rooms is open. Then it runs as one `go` to each released room in turn; a door
node is passed with the room after it; an order that ends in the plan's start room
ends on the dock, where the robot charges. Unreleased nodes (the horizon) wait for an
order update, which must start at the last released node (§6.6.3).

The operator always wins (issue 28): an order is refused while a person or the program
on the virtual port holds the controls, and after an operator's stop until an operator
releases it (`release`, as for the virtual port); a console that takes the controls
ends the fleet's mission at once (the service does it: RobotService.attach `yields`),
and the fleet reads why in `errors`.

Not thread-safe: the vehicle's own thread calls everything here (fleet/vehicle.py), but
for `hold`, which the service calls at an operator's stop.
"""

from __future__ import annotations

import collections
import math
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

from giraff_console.fleet.orders import ErrorType, NodeKind, Order, Refusal, read_order
from giraff_console.fleet.state_report import ActionState, Error, OrderProgress, VehicleFacts
from giraff_console.fleet.vocabulary import ActionStatus, ActionType, ErrorLevel, OperatingMode
from giraff_console.missions.docking import DOCK
from giraff_console.planning.floorplan import FloorPlan
from giraff_console.robot.mission import Outcome
from giraff_console.service import commands as c
from giraff_console.service.events import Controls, GoReported, RoomRenamed, ServiceEvent
from giraff_console.service.robot_service import RobotService

FLEET = "the fleet"
# What `state` keeps: the latest instant actions' states, and errors: an order's end
# until the next order, a refused message's or order's for WARNING_S.
MAX_ACTIONS = 32
MAX_ERRORS = 8
WARNING_S = 60.0
# How far the robot moves before the room it stands in is judged again.
ROOM_AGAIN_M = 0.05


class OrderRun:
    """The order under way (or the last), the instant actions, and the errors."""

    def __init__(
        self,
        service: RobotService,
        note: Callable[[str], None],
        max_speed: float,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.service = service
        self.note = note
        self.max_speed = max_speed
        self.clock = clock
        self.order: Order | None = None
        self.progress = OrderProgress()
        self.paused = False
        self._legs: collections.deque[str] = collections.deque()  # rooms still to go to
        # The room being gone to, and what `go` was asked for it (the dock, for the
        # start room at an order's end).
        self._leg: tuple[str, str] | None = None
        # Why the leg under way ends other than by arriving, when the vehicle knows first
        # (a cancel, a console that took the controls, the broker gone).
        self._ending: Error | None = None
        self._cancel: str | None = None  # the cancelOrder action waiting for the stop
        self.undocking: str | None = None  # the stopCharging action whose undock runs
        # Why an operator's stop holds the fleet, until an operator's `release`.
        self.held: str | None = None
        self.actions: collections.OrderedDict[str, ActionState] = collections.OrderedDict()
        self.errors: collections.deque[Error] = collections.deque(maxlen=MAX_ERRORS)
        self._warnings: collections.deque[tuple[float, Error]] = collections.deque(
            maxlen=MAX_ERRORS
        )
        self._room: tuple[tuple[float, float], str | None] | None = None

    def hold(self, why: str | None) -> None:
        """An operator's stop holds the fleet (`why`), or a `release` lets it go (None);
        called on the operator's thread, so only this is set."""
        self.held = why

    def warn(self, error: Error) -> None:
        """A refused message or order: said in `state` for WARNING_S."""
        self._warnings.append((self.clock() + WARNING_S, error))

    # -- what the robot service says -----------------------------------------------------

    def heard(self, event: ServiceEvent) -> None:
        if isinstance(event, GoReported):
            self._go_ended(event)
        elif isinstance(event, Controls):
            self._controls(event)
        elif isinstance(event, RoomRenamed):
            self._room = None  # the room it stands in may have a new name

    def _go_ended(self, event: GoReported) -> None:
        report = event.report
        # The fleet's leg: nobody else can start a mission while the fleet holds the
        # controls, and taking them ends the fleet's at once (the service).
        if self._leg is None or report.room != self._leg[1]:
            return
        room = self._leg[0]
        self._leg = None
        outcome = report.end.outcome
        if outcome in (Outcome.ARRIVED, Outcome.ARRIVED_UNVERIFIED) and self._ending is None:
            if outcome is Outcome.ARRIVED_UNVERIFIED:
                # There by the estimate alone (a plan without markers, none in sight): the
                # node is reached, and the fleet is told how little that is known.
                self.warn(
                    Error(
                        ErrorType.MISSION,
                        ErrorLevel.WARNING,
                        f"at {room}, unconfirmed: {report.end.detail}",
                        self._references(),
                    )
                )
            self._reached(room)
            self._next_leg()
            return
        ending = self._ending or self._why_ended(room, outcome, report.end.detail)
        self._ending = None
        self._end_order(ending)

    def _why_ended(self, room: str, outcome: Outcome, detail: str) -> Error:
        if outcome is Outcome.STOPPED_BY_OPERATOR:
            return Error(
                ErrorType.OPERATOR,
                ErrorLevel.WARNING,
                f"an operator stopped the robot on its way to {room}: {detail}",
                self._references(),
            )
        return Error(
            ErrorType.MISSION,
            ErrorLevel.WARNING,
            f"go {room}: {outcome.value}: {detail}",
            self._references(),
        )

    def _controls(self, controls: Controls) -> None:
        holder = controls.holder
        if self._leg is not None and holder not in (None, FLEET) and self._ending is None:
            # The service has ended the fleet's mission already; this says why.
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
            order = read_order(message, self.plan(), self.max_speed)
            current = self.order
            if current is not None and order.order_id == current.order_id:
                self._update(current, order)
            else:
                self._start(order)
        except Refusal as refusal:
            self._refused(refusal, message)
        finally:
            if self._leg is None:
                # Standing still: whatever the fleet asked, anyone may take the controls.
                self.service.let_go(FLEET)

    def _start(self, order: Order) -> None:
        if self.active:
            assert self.order is not None
            raise Refusal(
                ErrorType.ORDER,
                f"order {self.order.order_id} is under way: cancelOrder first, or update it",
            )
        self._may_drive()
        here = self.room_here()
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
            f"fleet: order {order.order_id}: {' → '.join(rooms)}"
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
        if not self.active and self.room_here() != end.node_id:
            # The order had ended, and the robot was driven elsewhere since (§6.6.4: an
            # update continues from where the last one left the vehicle).
            raise Refusal(
                ErrorType.ORDER_UPDATE,
                f"the robot is no longer at {end.node_id}, but in {self.room_here()}",
            )
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

    def may_drive(self) -> Refusal | None:
        """Why the fleet may not move the robot now, or None."""
        holder = self.service.controls().holder
        if holder not in (None, FLEET):
            return Refusal(
                ErrorType.OPERATOR, f"{holder} holds the controls: the operator wins over the fleet"
            )
        if self.held is not None:
            return Refusal(
                ErrorType.OPERATOR, f"{self.held}: the fleet waits until an operator's `release`"
            )
        others = self.service.started_by()
        if others not in (None, FLEET):
            # A mission of someone else's would be replaced by the fleet's: never.
            return Refusal(ErrorType.OPERATOR, f"a mission {others} started is under way")
        return None

    def _may_drive(self) -> None:
        refusal = self.may_drive()
        if refusal is not None:
            raise refusal

    def _next_leg(self, first: bool = False) -> None:
        order = self.order
        assert order is not None
        plan = self.plan()
        while self._legs:
            room = self._legs.popleft()
            if room == self.progress.last_node:
                self._reached(room)  # a room named twice in a row: there already
                continue
            # The start room at the very end of an order: onto the dock, to charge.
            last = not self._legs and not order.horizon
            goal = DOCK if last and room == plan.start else room
            reply = self.service.execute(c.Go(goal), FLEET)
            if reply.ok:
                self._leg = (room, goal)
                return
            if first:
                # Nothing has run: the order is refused, not failed.
                self.order, self.progress, self._legs = None, OrderProgress(), collections.deque()
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
        if not order.horizon:
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
            self.act(self._cancel, ActionType.CANCEL_ORDER.value, ActionStatus.FINISHED)
            self._cancel = None
        self.service.let_go(FLEET)

    @property
    def active(self) -> bool:
        """An order with something left to do: driving, or waiting for its horizon."""
        return bool(self.progress.nodes) or self._leg is not None

    @property
    def driving(self) -> bool:
        """Whether a mission of the fleet's runs: an order's leg, or an undock."""
        return self._leg is not None or self.undocking is not None

    def cancel(self, action_id: str) -> bool:
        """cancelOrder (§6.8): the order's leg is stopped, and the order ended once it
        has; False if there is no order."""
        if not self.active:
            return False
        self._cancel = action_id
        ending = Error(
            ErrorType.ORDER, ErrorLevel.WARNING, "cancelled by the fleet", self._references()
        )
        if self._leg is None:
            self._end_order(ending)  # standing at the horizon: nothing to stop
        else:
            self._ending = ending
            self.service.execute(c.StopMission(operator=False), FLEET)
        return True

    def _refused(self, refusal: Refusal, message: dict[str, Any]) -> None:
        references = [("orderId", str(message.get("orderId", "")))]
        if refusal.node_id is not None:
            references.append(("nodeId", refusal.node_id))
        self.warn(Error(refusal.kind, ErrorLevel.WARNING, refusal.description, tuple(references)))
        self.note(f"fleet: order {message.get('orderId')} refused: {refusal}")

    def _references(self) -> tuple[tuple[str, str], ...]:
        return (("orderId", self.progress.order_id),)

    def act(self, action_id: str, action_type: str, status: ActionStatus, result: str = "") -> None:
        """An instant action's state, kept for `state` (the latest MAX_ACTIONS)."""
        self.actions[action_id] = ActionState(action_id, action_type, status, result)
        self.actions.move_to_end(action_id)
        while len(self.actions) > MAX_ACTIONS:
            self.actions.popitem(last=False)

    # -- the broker --------------------------------------------------------------------

    def broker_lost(self, stop: bool) -> None:
        """The broker went; with `stop` (fleet.on_broker_lost), the order is ended."""
        if not stop:
            return
        if self._leg is not None and self._ending is None:
            self._ending = Error(
                ErrorType.BROKER,
                ErrorLevel.WARNING,
                "the broker went: stopped, as fleet.on_broker_lost says",
                self._references(),
            )
            self.service.execute(c.StopMission(operator=False), FLEET)
        elif self.active:
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
        now = self.clock()
        while self._warnings and self._warnings[0][0] < now:
            self._warnings.popleft()
        information: tuple[str, ...] = ()
        if self._leg is not None:
            information = (f"going to {self._leg[0]}",)
        elif self.active:
            information = (f"waiting at {self.progress.last_node} for the order's next release",)
        elif self.held is not None:
            information = (f"held: {self.held}",)
        return VehicleFacts(
            telemetry=telemetry,
            map_id=map_id,
            # Not driving an order: where it stands, wherever it was driven since.
            room=None if self.active else self.room_here(),
            progress=self.progress,
            mode=OperatingMode.MANUAL if holder not in (None, FLEET) else OperatingMode.AUTOMATIC,
            paused=self.paused and self.driving,
            driving=driving,
            errors=(*self.errors, *(error for _, error in self._warnings), *extra_errors),
            actions=tuple(self.actions.values()),
            information=information,
        )

    def room_here(self) -> str | None:
        """The room the robot stands in, judged again only once it has moved: on a plan
        without outlines the judging looks along the grid to every room's point."""
        pose = self.service.control.estimate().pose
        if self._room is None or math.dist(self._room[0], (pose.x, pose.y)) > ROOM_AGAIN_M:
            self._room = ((pose.x, pose.y), self.service.room_here())
        return self._room[1]

    def plan(self) -> FloorPlan:
        navigator = self.service.navigator
        if navigator is None:
            raise Refusal(ErrorType.ORDER, "the robot has no floor plan")
        return navigator.plan
