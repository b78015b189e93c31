"""Recordings: whatever the bytes of a session's control.log, meta.json and frame index,
opening it for playback gives entries or a SessionError, never a traceback (issue 12)."""

from __future__ import annotations

import contextlib
import json
import random
from pathlib import Path

from hypothesis import given

from giraff_console.recording.playback import as_exchange, frame_times, open_log
from giraff_console.recording.session import SessionError, SessionStart, read_meta
from tests.fuzz.inputs import FUZZ, cases, encoded, mutated, nested, raw_bytes, replaced

SAMPLE = Path(__file__).parents[2] / "recordings" / "sample"
# The first 40 lines of the sample's log keep each case cheap; they hold every flag.
LOG_SEED = b"".join((SAMPLE / "control.log").read_bytes().splitlines(keepends=True)[:40])
META_SEED = (SAMPLE / "meta.json").read_bytes()
FRAMES_SEED = (SAMPLE / "camera.frames.csv").read_bytes()[:400]


def dump(document: object) -> bytes:
    return json.dumps(document).encode()


def play(session: Path) -> None:
    """What the console does to open a session: its log, frame times, and start."""
    _, log = open_log(session)
    frame_times(session, log)
    SessionStart.from_meta(read_meta(session))
    for entry in log.entries:
        as_exchange(entry, 0.0)


def test_the_sample_plays(folder):
    session = folder / "seed"
    session.mkdir()
    for name in ("control.log", "meta.json", "camera.frames.csv"):
        (session / name).write_bytes((SAMPLE / name).read_bytes())
    play(session)


def test_a_meta_json_with_an_int_of_400_digits_is_refused(folder):
    session = folder / "huge"
    session.mkdir(exist_ok=True)
    (session / "meta.json").write_text('{"start": {"x": 1' + "0" * 400 + "}}")
    try:
        read_meta(session)
    except SessionError as error:
        assert str(error).startswith(f"{session / 'meta.json'}: number out of range")
    else:
        raise AssertionError("a 400-digit x loaded")


@FUZZ
@given(data=cases(raw_bytes, mutated(LOG_SEED), mutated(LOG_SEED), encoded(LOG_SEED)))
def test_any_control_log_plays_or_is_refused(folder, data):
    session = folder / "log"
    session.mkdir(exist_ok=True)
    (session / "control.log").write_bytes(data)
    with contextlib.suppress(SessionError):
        play(session)


def _meta_and_frames(rng: random.Random) -> bytes:
    return (
        rng.choice(
            (
                raw_bytes(rng),
                mutated(META_SEED)(rng),
                encoded(META_SEED)(rng),
                nested(rng),
                replaced(json.loads(META_SEED), dump)(rng),
                replaced(json.loads(META_SEED), dump)(rng),
            )
        )
        + b"\0"
        + rng.choice((FRAMES_SEED, mutated(FRAMES_SEED)(rng), raw_bytes(rng)))
    )


@FUZZ
@given(data=cases(_meta_and_frames))
def test_any_meta_json_and_frame_index_play_or_are_refused(folder, data):
    session = folder / "meta"
    session.mkdir(exist_ok=True)
    meta, _, frames = data.partition(b"\0")
    (session / "control.log").write_bytes(LOG_SEED)
    (session / "meta.json").write_bytes(meta)
    (session / "camera.frames.csv").write_bytes(frames)
    with contextlib.suppress(SessionError):
        play(session)
