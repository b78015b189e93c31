"""Junk for the daemon's socket (issue 30, "Typed refusals"; Done-when: "the socket fuzz
(malformed, truncated, oversized, wrong types, 10,000 cases) finds 0 exception texts in
replies, 0 crashes and 0 ticks later than 5 ms").

`junk_lines` makes the lines a client gone wrong might write: malformed JSON, lines cut
short, lines over the transport's limit, requests whose fields have the wrong type or
lie outside their bounds, unknown and wrong classes, deep nesting, huge numbers, NaN
and Infinity, unicode junk. Deterministic: the same seed gives the same lines, byte for
byte. None of them may move the robot: a line that this process's own decoding builds
into a request is drawn again unless the request is one of HARMLESS (asked by a console
that does not hold the controls, those move nothing), so that "the robot never moved"
measures the daemon, not luck.

`pelt` sends them to a daemon over its real socket as a console that takes no controls,
in bursts, and reads every answer: each line is answered once (transport.py: a line
that cannot be built is refused and skipped), so a burst is done when its answers are
in. `python_text` says whether an answer's words are Python's own (an exception's text,
a repr) rather than the daemon's.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import random
import re
import socket
import threading
import time
import typing
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from giraff_console.robot.deadman import Intent
from giraff_console.robot.telemetry import Telemetry
from giraff_console.service import commands as c
from giraff_console.service import wire
from giraff_console.service.console_hello import Asked, Hello
from giraff_console.service.daemon import Answered
from giraff_console.service.events import Reply
from giraff_console.service.transport import MAX_LINE

SEED = 30
# Requests that move nothing and change nothing, whoever asks: a junk line that decodes
# into one of these may be sent; into any other, it is drawn again.
# (Not View: it would start the camera's frames; not Poll: it changes what the loop asks.)
HARMLESS = (c.Status, c.Heartbeat, c.Halt, c.Pause, c.StopMission, c.Routes, c.Step, c.Seek,
            c.Rate)  # fmt: skip
# One line in this many is over the transport's limit (they are big: 1 MB each).
OVERSIZED_ONE_IN = 500
# Lines sent before their answers are waited for.
BURST = 16
# Seconds a burst's answers may take on a loaded 2-core machine.
ANSWER_TIMEOUT_S = 20.0

# What Python says and the daemon must not: exception names and messages, tracebacks,
# and the reprs of objects, bytes, dicts and lists.
_PYTHON_TEXT = re.compile(
    "|".join(
        [
            r"Traceback",
            r"\b[A-Z][A-Za-z]*(?:Error|Exception|Warning)\b",
            r"\bunhashable\b",
            r"has no attribute",
            r"not subscriptable",
            r"is not iterable",
            r"not callable",
            r"unexpected keyword",
            r"positional argument",
            r"codec can't",
            r"Expecting (?:value|property name|',' delimiter|':' delimiter)",
            r"line \d+ column \d+",
            r"\(char \d+\)",
            r"invalid literal",
            r"maximum recursion",
            r"Exceeds the limit",
            r"NoneType",
            r"<[\w.]+ object at 0x",
            r"<(?:class|enum|function|module) ",
            r"\bb'",
            r'\bb"',
            r"\{'",
            r"\['",
            r"\\x[0-9a-fA-F]{2}",
            r'File "',
        ]
    )
)


def python_text(text: str) -> str | None:
    """The first piece of `text` that is Python's own words, or None."""
    found = _PYTHON_TEXT.search(text)
    return found.group(0) if found else None


@dataclass(frozen=True)
class Junk:
    """One line, with its newline, and what it is (for the figures)."""

    line: bytes
    what: str


def junk_lines(count: int, seed: int = SEED) -> Iterator[Junk]:
    """`count` lines of junk for the daemon's socket."""
    rng = random.Random(seed)
    makers = [
        ("malformed", _malformed),
        ("truncated", _truncated),
        ("wrong type", _wrong_type),
        ("out of bounds", _out_of_bounds),
        ("unknown type", _unknown_type),
        ("deep nesting", _deep),
        ("huge number", _huge_number),
        ("nan/infinity", _not_finite),
        ("unicode junk", _unicode),
        ("bad shape", _bad_shape),
    ]
    for number in range(count):
        if number % OVERSIZED_ONE_IN == OVERSIZED_ONE_IN - 1:
            yield Junk(_oversized(rng), "oversized")
            continue
        while True:
            what, make = rng.choice(makers)
            line = make(rng, number).rstrip(b"\n").replace(b"\n", b" ") + b"\n"
            try:
                message = wire.decode(json.loads(line))
            except (ValueError, RecursionError, wire.WireError):
                yield Junk(line, what)
                break
            # Built into a request: only one that changes nothing may be sent.
            if not isinstance(message, Asked) or isinstance(message.request, HARMLESS):
                yield Junk(line, what)
                break


def _dumps(value: object) -> bytes:
    return json.dumps(value, separators=(",", ":")).encode() + b"\n"


def _asked(number: int, request: object) -> dict[str, object]:
    return {"type": "Asked", "number": number, "request": request}


# A valid value of each kind of field, within every request's bounds.
_VALID: dict[object, object] = {
    str: "kitchen", bool: True, int: 0, float: 0.5, Path: {"path": "/tmp/giraff-junk"},
    Intent: {"enum": "Intent", "value": "FORWARD"}, tuple[str, ...]: ["get bulk_data"],
}  # fmt: skip


def _request(rng: random.Random) -> dict[str, object]:
    """A request of any kind as a client would send it, every field valid."""
    kind = rng.choice(c.REQUESTS)
    hints = typing.get_type_hints(kind)  # without the bounds: the plain types
    data: dict[str, object] = {"type": kind.__name__}
    for f in dataclasses.fields(kind):
        hint = hints[f.name]
        plain = next((a for a in typing.get_args(hint) if a is not type(None)), hint)
        plain = hint if typing.get_origin(hint) is tuple else plain
        data[f.name] = "get bulk_data" if kind is c.Send else _VALID[plain]
    return data


# Values of every kind, to put where another belongs.
_VALUES: list[object] = [
    None, True, False, 0, -1, 1.5, -0.0, 2**63, -(2**63) - 1, "", "kitchen", "x" * 300,
    [], ["kitchen"], [1, 2, 3], {}, {"a": 1}, {"type": "Pose", "x": 1.0},
    {"type": "Halt"}, {"enum": "Intent", "value": "FORWARD"},
    {"enum": "LinkState", "value": "LOST"}, {"enum": "Intent"}, {"path": "/tmp"}, {"path": 5},
    {"bytes": "AAAA"}, {"bytes": "!!"},
    {"error": "GiraffError", "message": "x", "attrs": {}}, {"dict": {"type": 1}}, {"dict": 5},
    {"type": "Go", "room": "kitchen"}, {"type": None}, {"type": ["Go"]}, {"type": {"x": 1}},
]  # fmt: skip


def _wrong_type(rng: random.Random, number: int) -> bytes:
    request = _request(rng)
    fields = [key for key in request if key != "type"] or ["room"]
    request[rng.choice(fields)] = rng.choice(_VALUES)
    if rng.random() < 0.2:
        request[rng.choice(fields)] = rng.choice(_VALUES)
    return _dumps(_asked(number, request))


_BAD_TEXTS = ["", "x" * 65, "x" * 5000, "../../etc/passwd", "a/b", "kitchen\n", "living room",
              "get v\nset v 9", "\x00", "\x1b[2J", "dock;rm -rf ~", "é" * 70, "\ud800",
              "🙂"]  # fmt: skip
_BAD_NUMBERS = [-1, 3, 1e6, -1e6, 1e308, -1e308, 2001, 10**18, 5e-324, 0.001, 100.0]


def _out_of_bounds(rng: random.Random, number: int) -> bytes:
    """A request of the right shape whose value lies outside what the robot means."""
    request = _request(rng)
    fields = [key for key in request if key != "type"]
    if not fields:  # a request without fields: one that it does not have
        request[rng.choice(["room", "x", "__class__", "moves", "quick"])] = 1
        return _dumps(_asked(number, request))
    name = rng.choice(fields)
    value = request[name]
    if isinstance(value, bool):
        request[name] = rng.choice([0, 1, "true"])
    elif isinstance(value, str):
        request[name] = rng.choice(_BAD_TEXTS)
    elif isinstance(value, int | float):
        request[name] = rng.choice(_BAD_NUMBERS)
    elif isinstance(value, list):
        request[name] = rng.choice(
            [[], ["get v"] * 33, ["set v 9\nget p"], [rng.choice(_BAD_TEXTS)]]
        )
    else:
        request[name] = {"path": rng.choice(["x" * 5000, "/tmp/\x00"])}
    return _dumps(_asked(number, request))


def _unknown_type(rng: random.Random, number: int) -> bytes:
    name = rng.choice(["Foo", "__class__", "object", "Request", "Telemetry", "Hello", "Welcome",
                       "Answered", "Reply", "os.system", "<script>", "", "Go ", "go", "GO",
                       "x" * 500, "\u202eoG"])  # fmt: skip
    if rng.random() < 0.5:
        return _dumps({"type": name})
    return _dumps(_asked(number, {"type": name, "room": "kitchen"}))


def _deep(rng: random.Random, number: int) -> bytes:
    depth = rng.choice([50, 500, 990, 1200, 5000, 100_000])
    asked = '{"type":"Asked","number":1,"request":'
    opener, closer = rng.choice([("[", "]"), ('{"a":', "}"), (asked, "}"), ('{"dict":', "}")])
    inner = opener * depth + "1" + closer * depth
    if rng.random() < 0.5:
        return (inner + "\n").encode()
    return (
        f'{{"type":"Asked","number":{number},"request":{{"type":"Go","room":{inner}}}}}\n'.encode()
    )


def _huge_number(rng: random.Random, number: int) -> bytes:
    huge = rng.choice(["1e400", "-1e400", "9" * 400, "9" * 4301, "1" + "0" * 5000, "1e-400",
                       "123456789012345678901234567890", "0." + "0" * 400 + "1"])  # fmt: skip
    request = _request(rng)
    fields = [key for key in request if key != "type"] or ["to"]
    request[rng.choice(fields)] = "HUGE"
    text = json.dumps(_asked(number, request)).replace('"HUGE"', huge)
    if rng.random() < 0.3:
        text = f'{{"type":"Asked","number":{huge},"request":{{"type":"Status"}}}}'
    return (text + "\n").encode()


def _not_finite(rng: random.Random, number: int) -> bytes:
    token = rng.choice(["NaN", "Infinity", "-Infinity", "nan", "inf"])
    kind = rng.choice(["Speed", "Stalk", "Seek", "Rate", "Block", "Place"])
    field_ = {"Speed": "to", "Stalk": "to", "Seek": "by", "Rate": "times", "Block": "x",
              "Place": "heading"}[kind]  # fmt: skip
    extra = {"Block": ',"y":0', "Place": ',"room":"kitchen"'}.get(kind, "")
    request = f'{{"type":"{kind}","{field_}":{token}{extra}}}'
    return f'{{"type":"Asked","number":{number},"request":{request}}}\n'.encode()


def _unicode(rng: random.Random, number: int) -> bytes:
    junk = rng.choice([b"\xff\xfe", b"\xc3\x28", b"\xed\xa0\x80", b"\xf4\x90\x80\x80", b"\x00",
                       b"\xe2\x80\xae", b"\\ud800", b"\\udfff\\ud800"])  # fmt: skip
    where = rng.choice(["name", "value", "key", "bare"])
    if where == "bare":
        return junk * rng.randint(1, 50) + b"\n"
    if where == "key":
        start = f'{{"type":"Asked","number":{number},"request":{{"type":"Go","'.encode()
        return start + junk + b'":1}}\n'
    kind = "Go" if where == "name" else rng.choice(["Follow", "Teach", "Mark", "Door"])
    names = {"Go": "room", "Follow": "name", "Teach": "name", "Mark": "place", "Door": "door"}
    extra = b',"open":true' if kind == "Door" else b""
    start = f'{{"type":"Asked","number":{number},"request":{{"type":"{kind}","{names[kind]}":'
    return start.encode() + b'"kit' + junk + b'chen"' + extra + b"}}\n"


def _malformed(rng: random.Random, number: int) -> bytes:
    choice = rng.randrange(6)
    if choice == 0:
        return bytes(rng.randrange(32, 127) for _ in range(rng.randint(0, 80))) + b"\n"
    if choice == 1:
        return (
            bytes(rng.randrange(0, 256) for _ in range(rng.randint(1, 80))).replace(b"\n", b"")
            + b"\n"
        )
    if choice == 2:
        return rng.choice([b"{", b"}", b"[", b"]", b'"', b"{{}}", b"[,]", b'{"a"}', b"{'a': 1}",
                           b"None", b"True", b"undefined", b"", b" ", b"\t", b"\r"]) \
            + b"\n"  # fmt: skip
    if choice == 3:
        return _dumps(_asked(number, _request(rng))).replace(b",", b";", 1)
    if choice == 4:
        return _dumps(_asked(number, _request(rng)))[:-1] * 2 + b"\n"  # two on one line
    return rng.choice([b"1", b"-1", b'"text"', b"null", b"[]", b"{}", b"true", b"1e999"]) + b"\n"


def _truncated(rng: random.Random, number: int) -> bytes:
    line = _dumps(_asked(number, _request(rng)))
    return line[: rng.randrange(1, len(line) - 1)] + b"\n"


def _bad_shape(rng: random.Random, number: int) -> bytes:
    """A message of the right classes put together wrongly."""
    request = _request(rng)
    shapes: list[object] = [
        {"type": "Asked", "number": number},
        {"type": "Asked", "request": request},
        {"type": "Asked", "number": rng.choice(["1", 1.5, True, None, [1], 2**70]),
         "request": request},
        {"type": "Asked", "number": number, "request": None},
        {"type": "Asked", "number": number, "request": request, "extra": 1},
        {"type": "Asked", "number": number, "request": [request]},
        {"type": "Asked", "number": number,
         "request": {"type": "Asked", "number": 1, "request": request}},
        {"type": "Hello", "console": "again", "take": True},
        {"type": "Hello", "console": ["x"]},
        {"enum": "Intent", "value": "FORWARD"},
        {"error": "BoardError", "message": "x", "attrs": {"__class__": 1}},
        {"error": "Foo"},
        {"path": ["x"]},
        {"bytes": 5},
        {"type": "Answered", "number": 1, "reply": {"type": "Reply", "ok": True}},
        [request, request],
        {"dict": {"type": "Asked"}},
    ]  # fmt: skip
    return _dumps(rng.choice(shapes))


def _oversized(rng: random.Random) -> bytes:
    """Over the transport's limit: valid JSON, or junk without an end."""
    if rng.random() < 0.5:
        return _dumps(_asked(0, {"type": "Go", "room": "x" * (MAX_LINE + 1000)}))
    return b"[" * (MAX_LINE + 10) + b"\n"


# -- sending them -------------------------------------------------------------------------


@dataclass
class Findings:
    """What came of pelting a daemon."""

    sent: int = 0
    answered: int = 0
    by_kind: dict[str, int] = field(default_factory=dict)
    python_texts: list[tuple[str, str]] = field(default_factory=list)  # (junk's what, answer)
    unbuildable: int = 0  # lines from the daemon this end could not decode
    hung_up: int = 0
    seconds: float = 0.0
    ticks: int = 0
    late_ms: list[float] = field(default_factory=list)
    start: tuple[float, float] | None = None
    moved_m: float = 0.0  # the farthest the odometry went from where it started
    moving_ticks: int = 0  # ticks whose motor state said the wheels turned


class JunkClient:
    """A console on a raw socket that writes what it is given and keeps the answers."""

    def __init__(self, path: Path, findings: Findings) -> None:
        self.findings = findings
        self.replies: list[Reply] = []
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.sock.settimeout(ANSWER_TIMEOUT_S)
        self.sock.connect(str(path))
        self._changed = threading.Condition()
        self._whats: list[str] = []  # what each line sent was, to blame its answer
        self.closed = False
        self.sock.sendall(_dumps(wire.encode(Hello("socket junk", take=False))))
        self._reader = threading.Thread(target=self._read, name="junk-reader", daemon=True)
        self._reader.start()

    def ask(self, junk: list[Junk], timeout: float = ANSWER_TIMEOUT_S) -> bool:
        """Send these lines; whether all were answered within `timeout` seconds."""
        with self._changed:
            wanted = len(self.replies) + len(junk)
            self._whats.extend(j.what for j in junk)
        try:
            self.sock.sendall(b"".join(j.line for j in junk))
        except OSError:
            return False
        deadline = time.monotonic() + timeout
        with self._changed:
            while len(self.replies) < wanted and not self.closed:
                left = deadline - time.monotonic()
                if left <= 0:
                    break
                self._changed.wait(left)
            return len(self.replies) >= wanted

    def _read(self) -> None:
        buffer = b""
        try:
            while not self.closed:
                try:
                    chunk = self.sock.recv(1 << 16)
                except TimeoutError:
                    continue
                if not chunk:
                    break
                *lines, buffer = (buffer + chunk).split(b"\n")
                for line in lines:
                    self._heard(line)
        except OSError:
            pass  # closed under it
        finally:
            with self._changed:
                self.closed = True
                self._changed.notify_all()

    def _heard(self, line: bytes) -> None:
        findings = self.findings
        try:
            message = wire.decode(json.loads(line))
        except (ValueError, RecursionError, wire.WireError):
            findings.unbuildable += 1
            return
        if isinstance(message, Telemetry):
            findings.ticks += 1
            findings.late_ms.append(message.late_ms)
            pose = (message.pose.x, message.pose.y)
            findings.start = findings.start or pose
            findings.moved_m = max(findings.moved_m, math.dist(findings.start, pose))
            state = message.state
            if state is not None and (state.moving or abs(state.speed or 0.0) > 1e-3):
                findings.moving_ticks += 1
        elif isinstance(message, Answered):
            with self._changed:
                whats, count = self._whats, len(self.replies)
                what = whats[count] if count < len(whats) else "?"
                self.replies.append(message.reply)
                findings.answered += 1
                self._check(message.reply, what)
                self._changed.notify_all()

    def _check(self, reply: Reply, what: str) -> None:
        texts = [reply.text, *reply.lines]
        if reply.sent is not None:
            texts.append(reply.sent.why)
        for text in texts:
            if python_text(text) is not None:
                self.findings.python_texts.append((what, text))

    def close(self) -> None:
        self.closed = True
        with contextlib.suppress(OSError):
            self.sock.shutdown(socket.SHUT_RDWR)
        self.sock.close()
        self._reader.join(5.0)


def pelt(path: Path, count: int, seed: int = SEED) -> Findings:
    """`count` junk lines to the daemon at `path`, BURST at a time, each burst's answers
    waited for; a console hung up on (or not answered in time) is counted, and a new one
    goes on."""
    findings = Findings()
    started = time.monotonic()
    client = JunkClient(path, findings)
    lines = list(junk_lines(count, seed))
    try:
        for first in range(0, len(lines), BURST):
            batch = lines[first : first + BURST]
            for junk in batch:
                findings.by_kind[junk.what] = findings.by_kind.get(junk.what, 0) + 1
            findings.sent += len(batch)
            if not client.ask(batch):
                findings.hung_up += 1
                client.close()
                client = JunkClient(path, findings)
    finally:
        client.close()
    findings.seconds = time.monotonic() - started
    return findings


def replies_to(path: Path, lines: Sequence[bytes]) -> list[Reply]:
    """The daemon's answers to these lines from a new console; fewer if it gives fewer."""
    client = JunkClient(path, Findings())
    try:
        client.ask([Junk(line, "asked") for line in lines], 10.0)
        return list(client.replies)
    finally:
        client.close()


def status_after(path: Path) -> Reply | None:
    """The daemon's answer to `status` from a new console, or None if it gives none."""
    replies = replies_to(path, [_dumps(wire.encode(Asked(1, c.Status())))])
    return replies[0] if replies else None
