"""The Giraff as VDA 5050's factsheet describes a vehicle (§6.15): what it is, what it
can do and what it cannot, truthfully, so that a fleet manager plans with the real
robot. The figures are the thesis's and the settings' (motion limits, the robot's
radius), not a catalogue's."""

from __future__ import annotations

from typing import Any

from giraff_console.fleet.orders import MAX_NODES
from giraff_console.settings import Settings

# The thesis's Giraff (§1.2): about 1.6 m tall, a base some 0.5 m across.
HEIGHT_M = 1.6
# The instant actions this vehicle does (fleet/vehicle.py); it takes no node or edge
# actions.
INSTANT_ACTIONS = ("cancelOrder", "startPause", "stopPause", "startCharging", "stopCharging",
                   "initPosition", "stateRequest", "factsheetRequest")  # fmt: skip


def factsheet(settings: Settings) -> dict[str, Any]:
    motion, radius = settings.motion, settings.robot_radius
    return {
        "typeSpecification": {
            "seriesName": "Giraff",
            "seriesDescription": "telepresence robot for elder care: two drive wheels, a "
            "tiltable head with a camera (giraff-console)",
            "agvKinematic": "DIFF",
            "agvClass": "CARRIER",
            "maxLoadMass": 0.0,
            # Fiducial markers on the walls (ArUco, thesis §2.4.2) and odometry between
            # them: the standard's nearest word for such markers is DMC.
            "localizationTypes": ["DMC"],
            "navigationTypes": ["AUTONOMOUS"],
        },
        "physicalParameters": {
            "speedMin": 0.0,
            "speedMax": motion.v_max,
            "accelerationMax": motion.a_max,
            "decelerationMax": motion.a_max,
            "heightMin": HEIGHT_M,
            "heightMax": HEIGHT_M,
            "width": 2 * radius,
            "length": 2 * radius,
        },
        "protocolLimits": {
            "maxStringLens": {"msgLen": 256 * 1024, "idLen": 64},
            "maxArrayLens": {"order.nodes": MAX_NODES, "order.edges": MAX_NODES - 1},
            "timing": {
                # An order is checked whole when it comes (a few milliseconds, a long one
                # up to tens): one every 0.1 s is read as it comes.
                "minOrderInterval": 0.1,
                "minStateInterval": 0.1,
                "defaultStateInterval": 1.0,
            },
        },
        "protocolFeatures": {
            "optionalParameters": [],
            "agvActions": [
                {"actionType": action, "actionScopes": ["INSTANT"]} for action in INSTANT_ACTIONS
            ],
        },
        "agvGeometry": {},
        "loadSpecification": {},
    }
