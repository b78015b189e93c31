"""Frame processors as plug-ins: a frame goes in, an overlay and data come out (§3.6, B.9)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import cv2
import numpy as np

# FAST's threshold in the thesis (B.9), and its pink: BGR (128, 0, 255).
FAST_THRESHOLD = 50
PINK = (128, 0, 255)
# The Canny thresholds of the thesis's demonstration (B.9, Figure 5.1).
CANNY_LOW, CANNY_HIGH = 20, 50


@dataclass
class Processed:
    """What a processor made of a frame: the image to show, and what it found."""

    image: np.ndarray
    data: dict[str, object] = field(default_factory=dict)


class FrameProcessor(Protocol):
    """Takes the image so far and the grey frame; returns the image to show and its data."""

    name: str

    def process(self, image: np.ndarray, grey: np.ndarray) -> Processed: ...


class FastCorners:
    """FAST corners (Rosten and Drummond [7]), drawn as pink circles as in B.9."""

    name = "fast"

    def __init__(self, threshold: int = FAST_THRESHOLD) -> None:
        self.detector = cv2.FastFeatureDetector_create(threshold=threshold)

    def process(self, image: np.ndarray, grey: np.ndarray) -> Processed:
        keypoints = self.detector.detect(grey)
        shown = cv2.drawKeypoints(image, keypoints, None, PINK)
        return Processed(shown, {"keypoints": len(keypoints), "corners": [k.pt for k in keypoints]})


class CannyEdges:
    """Canny edges over the whole frame, as in the thesis's Figure 5.1."""

    name = "canny"

    def process(self, image: np.ndarray, grey: np.ndarray) -> Processed:
        edges = cv2.Canny(grey, CANNY_LOW, CANNY_HIGH)
        return Processed(
            cv2.cvtColor(edges, cv2.COLOR_GRAY2BGR), {"edge_pixels": int(np.count_nonzero(edges))}
        )


class Pipeline:
    """Runs the enabled processors in order on each frame."""

    def __init__(self, processors: list[FrameProcessor]) -> None:
        self.processors = {p.name: p for p in processors}
        self.enabled: list[str] = []

    def toggle(self, name: str) -> bool:
        """Switch a processor on or off; returns whether it is on now."""
        if name not in self.processors:
            raise KeyError(f"no processor called {name!r}: {', '.join(self.processors)}")
        if name in self.enabled:
            self.enabled.remove(name)
            return False
        self.enabled.append(name)
        return True

    def run(self, image: np.ndarray) -> Processed:
        grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        result = Processed(image)
        for name in self.enabled:
            step = self.processors[name].process(result.image, grey)
            result = Processed(step.image, {**result.data, **step.data})
        return result
