"""A camera image as terminal text: two pixels a cell with the upper half block.

Each cell shows its upper pixel as the foreground of "▀" and its lower pixel as the
background. Colours are quantised, so that neighbouring cells of one colour merge into
one styled run and a frame stays small on the wire, in truecolor or, for terminals
without it, the 256-colour palette.
"""

from __future__ import annotations

import cv2
import numpy as np
from rich.color import Color
from rich.segment import Segment
from rich.style import Style

UPPER_HALF = "▀"
# Levels per channel after quantisation: 16 keeps images recognisable and runs long.
DEFAULT_LEVELS = 16


def fit(width: int, height: int, columns: int, rows: int) -> tuple[int, int]:
    """The largest pixel size within `columns` x 2*`rows` that keeps the aspect ratio."""
    scale = min(columns / width, 2 * rows / height)
    return max(1, round(width * scale)), max(2, 2 * round(height * scale / 2))


def quantise(rgb: np.ndarray, levels: int) -> np.ndarray:
    """Each channel snapped to the middle of one of `levels` bands."""
    step = 256 // levels
    return (rgb // step) * step + step // 2


def xterm_256(rgb: np.ndarray) -> np.ndarray:
    """The nearest colour of the xterm 6x6x6 cube (indices 16-231) for each pixel."""
    levels = np.array([0, 95, 135, 175, 215, 255])
    index = np.abs(rgb[..., None].astype(np.int16) - levels).argmin(axis=-1)
    return 16 + 36 * index[..., 0] + 6 * index[..., 1] + index[..., 2]


class HalfBlockRenderer:
    """Turns BGR images into lines of styled segments; caches the styles it has made."""

    def __init__(self, truecolor: bool = True, levels: int = DEFAULT_LEVELS) -> None:
        self.truecolor = truecolor
        self.levels = levels
        self._styles: dict[tuple[int, int], Style] = {}

    def render(self, image: np.ndarray, columns: int, rows: int) -> list[list[Segment]]:
        """At most `columns` x `rows` cells; the picture is centred, aspect kept."""
        height, width = image.shape[:2]
        size = fit(width, height, columns, rows)
        small = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
        rgb = cv2.cvtColor(small, cv2.COLOR_BGR2RGB)
        if self.truecolor:
            q = quantise(rgb, self.levels).astype(np.int32)
            codes = (q[..., 0] << 16) | (q[..., 1] << 8) | q[..., 2]
        else:
            codes = xterm_256(rgb).astype(np.int32)
        pad = " " * ((columns - size[0]) // 2)
        lines = []
        for row in range(0, size[1], 2):
            line = [Segment(pad)] if pad else []
            line += self._runs(codes[row], codes[row + 1])
            lines.append(line)
        return lines

    def _runs(self, upper: np.ndarray, lower: np.ndarray) -> list[Segment]:
        """One segment per run of cells with the same two colours."""
        pairs = (upper.astype(np.int64) << 24) | lower
        breaks = np.flatnonzero(np.diff(pairs)) + 1
        starts = np.concatenate(([0], breaks))
        ends = np.concatenate((breaks, [len(pairs)]))
        return [
            Segment(
                UPPER_HALF * int(end - start), self._style(int(upper[start]), int(lower[start]))
            )
            for start, end in zip(starts, ends, strict=True)
        ]

    def _style(self, upper: int, lower: int) -> Style:
        style = self._styles.get((upper, lower))
        if style is None:
            style = Style(color=self._colour(upper), bgcolor=self._colour(lower))
            self._styles[(upper, lower)] = style
        return style

    def _colour(self, code: int) -> Color:
        if self.truecolor:
            return Color.from_rgb(code >> 16, (code >> 8) & 0xFF, code & 0xFF)
        return Color.from_ansi(code)
