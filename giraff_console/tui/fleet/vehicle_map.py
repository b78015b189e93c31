"""The selected robot on its map: the console's own map drawing (tui/map_view.py) when
the robot says it is on this view's floor plan (its state's mapId is the plan's name),
with the rooms its order still has to reach; otherwise which map it is on and where."""

from __future__ import annotations

import math
import os
from dataclasses import replace

from textual.app import ComposeResult
from textual.containers import Vertical
from textual.widgets import Static

from giraff_console.fleet.master import Vehicle
from giraff_console.planning.floorplan import FloorPlan
from giraff_console.tui.map_scene import MapScene
from giraff_console.tui.map_view import MapView


class VehicleMap(Vertical):
    """A line saying where the robot is, above the map it is on."""

    DEFAULT_CSS = """
    VehicleMap { height: 1fr; }
    VehicleMap > #where { height: 2; }
    """

    def __init__(self, plan: FloorPlan | None, scene: MapScene | None, **kwargs) -> None:
        """`scene`: the plan's still parts (map_scene.plan_scene); None with no plan or
        a plan with nothing to draw."""
        super().__init__(**kwargs)
        self.plan = plan
        self.scene = scene

    def compose(self) -> ComposeResult:
        yield Static("no robot selected", id="where")
        truecolor = os.environ.get("COLORTERM") in ("truecolor", "24bit")
        yield MapView(truecolor, id="fleet-map")

    def on_mount(self) -> None:
        self.where = self.query_one("#where", Static)
        self.map_view = self.query_one(MapView)
        if self.scene is not None:
            self.map_view.show(self.scene)
        self._shown: tuple[object, ...] | None = None

    def show(self, vehicle: Vehicle | None) -> None:
        """Where `vehicle` is; the plan alone for None."""
        state = vehicle.state if vehicle is not None else None
        position = state.position if state is not None else None
        key = (vehicle.name if vehicle is not None else None, position,
               state.nodes_left if state is not None else None)  # fmt: skip
        if key == self._shown:
            return
        self._shown = key
        if vehicle is None or state is None or position is None:
            words = "no robot selected" if vehicle is None else f"{vehicle.name}: where unknown"
            self.where.update(words)
            self.map_view.display = self.scene is not None
            if self.scene is not None:
                self.map_view.show(self.scene)
            return
        at = (f"x {position.x:.2f} m, y {position.y:.2f} m, "
              f"heading {math.degrees(position.theta):.0f}°")  # fmt: skip
        lost = "" if position.initialized else " (position not known yet)"
        on_plan = self.plan is not None and position.map_id == self.plan.name
        if not on_plan or self.scene is None:
            self.where.update(f"{vehicle.name} in {state.last_node_id}, on map "
                              f"{position.map_id!r}, not this view's: {at}{lost}")  # fmt: skip
            self.map_view.display = False
            return
        assert self.plan is not None
        self.where.update(f"{vehicle.name} in {state.last_node_id}: {at}{lost}")
        self.map_view.display = True
        # The rooms still to reach, as the cyan path: where the order takes it.
        rooms = self.plan.rooms
        path = ((position.x, position.y), *(rooms[n].at for n in state.nodes_left if n in rooms))
        self.map_view.show(replace(self.scene, robot=(position.x, position.y, position.theta),
                                   path=path if len(path) > 1 else ()))  # fmt: skip
