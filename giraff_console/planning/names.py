"""A name the operator typed that is not there, and the ones it is most like.

`go kitchn` answered with all 32 of a care home's rooms, which fill a narrow log; the
nearest names (difflib's ratio, whatever the case; the likest first, then in order) say
what was meant in a line. With none near, a few names are listed, and more are
counted, with where to find them.
"""

from __future__ import annotations

import difflib
from collections.abc import Collection

# At most this many suggestions, each at least this like the name typed (difflib's
# ratio: "kitchn" is 0.92 like "kitchen", "kitchen" 0.4 like "lobby").
SUGGESTIONS = 3
LIKE = 0.6
# Listed in full up to this many; more are counted.
LISTED = 12


def no_such(kind: str, name: str, known: Collection[str], where: str = "") -> str:
    """ "no room called 'kitchn': did you mean kitchen?", or the `known` names when none is
    like `name` (counted, with `where` to find them, when there are many)."""
    said = f"no {kind} called {name!r}"
    likeness = {other: difflib.SequenceMatcher(None, name.casefold(), other.casefold()).ratio()
                for other in known}  # fmt: skip
    close = sorted((o for o, r in likeness.items() if r >= LIKE), key=lambda o: (-likeness[o], o))
    close = close[:SUGGESTIONS]
    if close:
        return f"{said}: did you mean {' or '.join(close)}?"
    if not known:
        return f"{said}: there are none"
    if len(known) <= LISTED:
        return f"{said} ({kind}s: {', '.join(sorted(known))})"
    return f"{said}, nor any like it among the {len(known)} {kind}s" + (
        f" ({where})" if where else ""
    )
