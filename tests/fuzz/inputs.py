"""What the fuzz tests feed the console's readers: bytes, mutations of real files, wrong
encodings, huge numbers, NaN and deep nesting (issue 12: no traceback for any input); and
the bombs (issue 30): aliases that expand a billion times, image headers that claim 10
gigapixels, files that never end or never open.

Every kind runs FUZZ_EXAMPLES cases, derandomized so that CI sees the same ones every
time; GIRAFF_FUZZ_EXAMPLES raises or lowers that for a longer hunt or a quick look.
"""

from __future__ import annotations

import os
import random
import struct
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

FUZZ_EXAMPLES = int(os.environ.get("GIRAFF_FUZZ_EXAMPLES", "10000"))
FUZZ = settings(
    max_examples=FUZZ_EXAMPLES,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)

# Byte strings that trip readers: numbers out of range, NaN, YAML's tags and anchors,
# dates that are not dates, NUL, bytes that are not UTF-8, BOMs, and brackets.
TOKENS = (
    b"nan", b".nan", b"NaN", b".inf", b"-.inf", b"inf", b"-inf", b"1e308", b"1.0e400",
    b"-1.0e400", b"1e999", b"9" * 400, b"9" * 4400, b"-0", b"0x7fffffff", b"0o777",
    b"~", b"null", b"true", b"[]", b"{}", b"''", b'""', b"\xff", b"\xfe", b"\x00", b"\x80",
    b"\xef\xbb\xbf", b"\xc3", b"&a [1, 2]", b"*a", b"*b", b"!!binary", b"!!float",
    b"!!python/object:os.system", b"? [a, b]", b"<<: *a", b"2024-13-45", b"2024-02-30",
    b"- ", b": ", b"\n", b"\r", b"\t", b'"', b"'", b"#", b"%YAML 1.1\n---", b"---", b"...",
    b"[" * 300, b"{a: " * 100, b"- " * 200, b"=", b"[[", b"]]", b'"""', b"\\u0000",
)  # fmt: skip

# Values a structured mutation puts where the file had one of its own.
VALUES: tuple[Any, ...] = (
    float("nan"), float("inf"), -float("inf"), 1e308, -1e308, 10**400, -(10**400), 2**63,
    -1, 0, 0.0, 1e-320, True, False, None, "", "x" * 2000, "é\u0000\ufffd", [], {},
    [1, 2, 3, 4, 5], {"a": 1}, [[[[[[[[[[[[[[[[[[[[[[[[[]]]]]]]]]]]]]]]]]]]]]]]]],
)  # fmt: skip


def deep(depth: int, opening: bytes, closing: bytes) -> bytes:
    return opening * depth + closing * depth


# Each case is made from one drawn number by a seeded Random: hypothesis spends
# milliseconds per drawn value on a busy machine, and 10,000 cases must fit in CI time.
Maker = Callable[[random.Random], bytes]


def cases(*makers: Maker) -> st.SearchStrategy[bytes]:
    """Cases from `makers` in turn, each from its own seed."""
    return st.integers(0, 2**63).map(lambda n: _make(makers, n))


def _make(makers: tuple[Maker, ...], n: int) -> bytes:
    rng = random.Random(n)
    return makers[n % len(makers)](rng)


def raw_bytes(rng: random.Random) -> bytes:
    return rng.randbytes(rng.randrange(512))


def mutated(seed: bytes) -> Maker:
    """`seed` with a few bytes flipped, cut, copied or replaced by tokens."""

    def make(rng: random.Random) -> bytes:
        data = bytearray(seed)
        for _ in range(rng.randint(1, 6)):
            at = rng.randrange(len(data) + 1)
            op = rng.randrange(6)
            if op == 0 and at < len(data):
                data[at] = rng.randrange(256)
            elif op == 1:
                data[at:at] = rng.choice(TOKENS)
            elif op == 2:
                del data[at : at + rng.randint(1, 64)]
            elif op == 3:
                end = rng.randint(at, min(len(data), at + 200))
                data[at:at] = data[at:end] * rng.randint(1, 4)
            elif op == 4:
                data[at:at] = rng.randbytes(rng.randrange(16))
            else:
                del data[at:]
        return bytes(data)

    return make


def encoded(seed: bytes) -> Maker:
    """The same text in an encoding the console does not read, or with a BOM."""
    text = seed.decode("utf-8")
    variants = [
        text.encode("utf-16"),
        text.encode("utf-16-le"),
        text.encode("utf-32"),
        b"\xef\xbb\xbf" + seed,
        text.replace("e", "\u00e9").encode("latin-1", "replace"),
        text.encode("cp037", "replace"),
    ]
    return lambda rng: rng.choice(variants)


def nested(rng: random.Random) -> bytes:
    """Brackets and block lists nested deeper than any parser should recurse."""
    n = rng.choice((rng.randint(1, 200), rng.randint(1, 100_000)))
    return rng.choice(
        (
            deep(n, b"[", b"]"),
            deep(n, b"{a: ", b"}"),
            b"".join(b"  " * i + b"- \n" for i in range(min(n, 400))),
            b"a: " + deep(n, b"[", b"]"),
            b"- " * n + b"x",
        )
    )


def replaced(document: Any, dump: Callable[[Any], bytes]) -> Maker:
    """`document` (parsed from a seed) with one value, anywhere in it, replaced by one
    of VALUES or deleted, then written by `dump`: the mutations that get past the
    parser to the checks."""
    paths = list(_paths(document, ()))

    def make(rng: random.Random) -> bytes:
        changed = document
        for _ in range(rng.randint(1, 3)):
            path = rng.choice(paths)
            changed = _with(changed, path, rng.choice(VALUES), rng.random() < 0.3)
        return dump(changed)

    return make


def _paths(value: Any, path: tuple[Any, ...]) -> Iterator[tuple[Any, ...]]:
    yield path
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _paths(item, (*path, key))
    elif isinstance(value, list):
        for i, item in enumerate(value):
            yield from _paths(item, (*path, i))


def _with(value: Any, path: tuple[Any, ...], new: Any, delete: bool) -> Any:
    """`value` with the item at `path` set to `new` or deleted; a path that an earlier
    change made meaningless leaves `value` as it is."""
    if not path:
        return new
    head, rest = path[0], path[1:]
    if isinstance(value, dict) and head in value:
        copy: Any = dict(value)
    elif isinstance(value, list) and isinstance(head, int) and head < len(value):
        copy = list(value)
    else:
        return value
    if delete and not rest:
        del copy[head]
    else:
        copy[head] = _with(value[head], rest, new, delete)
    return copy


def file_cases(seed: bytes, structured: Maker) -> st.SearchStrategy[bytes]:
    """Everything at once: raw bytes, mutated seeds, other encodings, nesting, and the
    structured mutations `structured` makes for this kind of file."""
    mutate = mutated(seed)
    return cases(raw_bytes, mutate, mutate, encoded(seed), nested, structured, structured)


# Files that would take a reader all the memory a robot's PC has, or all the time there is
# (issue 30): each is a few bytes on disk, or no file at all.


def laughs(levels: int = 9, wide: int = 10) -> bytes:
    """A "billion laughs": `wide`**`levels` nodes with its aliases expanded, in under a
    kilobyte, each level a list of `wide` aliases of the one before."""
    lines = [b"a0: &a0 [lol]"]
    for level in range(1, levels + 1):
        aliases = b", ".join([b"*a%d" % (level - 1)] * wide)
        lines.append(b"a%d: &a%d [%s]" % (level, level, aliases))
    return b"\n".join(lines) + b"\n"


def png(width: int, height: int, rows: bytes | None = None) -> bytes:
    """A grey PNG of `width` x `height` (8 bits a pixel). With `rows` (each row's filter
    byte and pixels, compressed), a real one; without, its header alone, claiming the
    size: no decoder should ever get that far."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        check = struct.pack(">I", zlib.crc32(kind + data))
        return struct.pack(">I", len(data)) + kind + data + check

    header = chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
    body = b"" if rows is None else chunk(b"IDAT", rows) + chunk(b"IEND", b"")
    return b"\x89PNG\r\n\x1a\n" + header + body


def white_rows(width: int, height: int) -> bytes:
    """The compressed rows of an all-white `width` x `height` grey PNG, made a row at a
    time: a 12000 x 12000 one is 144 MB of pixels but a few hundred kB compressed."""
    compressor = zlib.compressobj(9)
    row = b"\x00" + b"\xff" * width
    return b"".join(compressor.compress(row) for _ in range(height)) + compressor.flush()


def pgm_header(width: int, height: int) -> bytes:
    """A PGM's header claiming `width` x `height`, and no pixels after it."""
    return b"P5\n%d %d\n255\n" % (width, height)


def sparse(path: Path, size: int) -> Path:
    """A file at `path` whose size says `size` bytes and which holds none on disk: a
    reader that trusts the size before reading refuses it at once."""
    with path.open("wb") as file:
        file.truncate(size)
    return path


def fifo(path: Path) -> Path:
    """A named pipe at `path` with nobody writing: opening it for reading blocks."""
    os.mkfifo(path)
    return path


def dev_zero(path: Path) -> Path:
    """A link at `path` to /dev/zero, which gives zeros for ever whatever size it says."""
    path.symlink_to("/dev/zero")
    return path
