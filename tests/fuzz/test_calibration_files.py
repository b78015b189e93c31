"""Camera calibrations: whatever their bytes, Undistortion.from_file gives a calibration,
an OSError, or a CalibrationError, never a traceback (issue 12)."""

from __future__ import annotations

import contextlib
import random

import numpy as np
from hypothesis import given

from giraff_console.camera.processors import CalibrationError, Undistortion
from tests.fuzz.inputs import FUZZ, cases, encoded, mutated, nested, raw_bytes

# An OpenCV FileStorage calibration as cv2.FileStorage writes one.
SEED = b"""\
%YAML:1.0
---
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 300., 0., 320., 0., 300., 240., 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 4
   cols: 1
   dt: d
   data: [ -5.0000000000000003e-02, 1.0000000000000000e-02, 0., 0. ]
image_width: 640
image_height: 480
"""
NUMBERS = (b".nan", b"nan", b".Inf", b"-.Inf", b"1e308", b"1e999", b"-1", b"0", b"9" * 400)


def number_changed(rng: random.Random) -> bytes:
    """A number of the seed replaced: NaN, huge, negative, or rows and cols that lie."""
    words = SEED.split(b" ")
    numeric = [
        i for i, word in enumerate(words) if word.rstrip(b",\n").replace(b".", b"")[-1:].isdigit()
    ]
    i = rng.choice(numeric)
    words[i] = rng.choice(NUMBERS) + (b"," if words[i].endswith(b",") else b"")
    return b" ".join(words)


def test_the_seed_is_a_good_calibration(folder):
    path = folder / "seed.yaml"
    path.write_bytes(SEED)
    assert np.allclose(Undistortion.from_file(str(path)).camera_matrix[0], [300, 0, 320])


@FUZZ
@given(data=cases(raw_bytes, mutated(SEED), encoded(SEED), nested, number_changed, number_changed))
def test_any_bytes_give_a_calibration_or_a_typed_error(folder, data):
    path = folder / "calibration.yaml"
    path.write_bytes(data)
    with contextlib.suppress(OSError, CalibrationError):
        Undistortion.from_file(str(path))
