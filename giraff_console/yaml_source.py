"""Parsing the YAML people write (floor plans, maps, routes, patrols, camera
calibrations), whatever its bytes.

Every failure comes out as one YamlSourceError with the line where it is known, which
each reader turns into its own typed error (issue 12: no traceback for any input).
Nesting is bounded before parsing: libyaml recurses in C and crashes the process on a
file of 100,000 `[`, and PyYAML's own parser takes seconds on a few thousand. So is the
size of the document with its aliases expanded (issue 30): PyYAML builds an alias as the
same object as its anchor, so a "billion laughs" of a few hundred bytes loads at once,
and then whoever walks it (the line finder, the checks) walks a billion nodes. The nodes
are counted from libyaml's events, which cost no memory, before any node is built.
"""

from __future__ import annotations

from typing import Any

import yaml

from giraff_console.file_limits import current, raising

# No hand-written file of ours nests past a handful of levels.
MAX_NESTING = 100
_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class YamlSourceError(Exception):
    """Bytes that are not a YAML document this console reads; `line` counts from 1."""

    def __init__(self, line: int | None, message: str) -> None:
        super().__init__(message)
        self.line, self.message = line, message


def too_deep(text: str) -> int | None:
    """The first line nested deeper than MAX_NESTING, by an upper bound on its depth:
    the brackets open before it and on it, its indentation, and its block indicators
    (`- `, `? `, `: `). Brackets and indicators inside quotes count too: overcounting
    only refuses sooner. Counted with str.count, so that a long file costs little."""
    flow_depth = 0
    for number, line in enumerate(text.split("\n"), start=1):
        opens = line.count("[") + line.count("{")
        indicators = line.count("- ") + line.count("? ") + line.count(": ") + line.count("-\t")
        indent = len(line) - len(line.lstrip(" \t"))
        if flow_depth + opens + indent + indicators + 1 > MAX_NESTING:
            return number
        flow_depth = max(flow_depth + opens - line.count("]") - line.count("}"), 0)
    return None


def parse_yaml(data: bytes) -> tuple[yaml.Node | None, Any]:
    """The node tree (for the lines of keys) and the document; YamlSourceError if not."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as error:
        line = data.count(b"\n", 0, error.start) + 1
        raise YamlSourceError(line, f"not UTF-8 text (byte {data[error.start]:#04x})") from None
    deep = too_deep(text)
    if deep is not None:
        raise YamlSourceError(deep, f"nested more than {MAX_NESTING} levels deep")
    try:
        _count_nodes(text)
        loader = _LOADER(text)
        try:
            node = loader.get_single_node()
            return node, loader.construct_document(node) if node is not None else None
        finally:
            loader.dispose()
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        what = ", ".join(filter(None, (error.context, error.problem)))
        raise YamlSourceError(mark.line + 1 if mark else None, f"not YAML: {what}") from None
    except yaml.YAMLError as error:
        raise YamlSourceError(None, f"not YAML: {' '.join(str(error).split())[:200]}") from None
    except (ValueError, TypeError, LookupError, ArithmeticError, RecursionError) as error:
        # PyYAML's constructors: a date like 2024-13-45, an int of 5,000 digits, an empty
        # `!!float` (IndexError).
        message = " ".join(str(error).split())[:200] or type(error).__name__
        raise YamlSourceError(None, f"not YAML this console reads: {message}") from None


def _count_nodes(text: str) -> None:
    """YamlSourceError at the line where the document, its aliases expanded, grows past
    the `yaml_nodes` limit, or where an alias names a node that holds it (a list that
    contains itself, which every walk of it would follow for ever)."""
    most = current().yaml_nodes
    total = 0
    # Each anchor's node, by its size once it is closed; the collections still open,
    # with their anchors and the count at their start.
    sizes: dict[str, int] = {}
    open_: list[tuple[str | None, int]] = []
    loader = _LOADER(text)
    try:
        while (event := loader.get_event()) is not None:
            line = event.start_mark.line + 1 if event.start_mark else None
            if isinstance(event, yaml.AliasEvent):
                if any(anchor == event.anchor for anchor, _ in open_):
                    message = f"the alias *{event.anchor} is inside the node it names"
                    raise YamlSourceError(line, f"{message}: a list or mapping that holds itself")
                total += sizes.get(event.anchor, 1)  # an unknown one the composer reports
            elif isinstance(event, yaml.ScalarEvent):
                total += 1
                if event.anchor is not None:
                    sizes[event.anchor] = 1
            elif isinstance(event, yaml.CollectionStartEvent):
                total += 1
                open_.append((event.anchor, total))
            elif isinstance(event, yaml.CollectionEndEvent):
                anchor, start = open_.pop()
                if anchor is not None:
                    sizes[anchor] = total - start + 1
            if total > most:
                message = f"more than {most:,} YAML nodes with its aliases expanded"
                raise YamlSourceError(line, f"{message} ({raising('yaml_nodes')})")
    finally:
        loader.dispose()
