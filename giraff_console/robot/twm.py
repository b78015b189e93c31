"""Curves as one command on Giraff-X: a move's settings folded into `set twm` (issue 13).

Giraff-X takes `set twm vg cdp vgr v p 0`, a whole curved move in one command; it was
added because sending the same parameters as several `set`s made the motors jerk and
pause briefly (wire-facts, "Later firmware"). Teleop and the missions build their moves
as the sets the board does not hold yet followed by `set p`; on a board that has twm,
the control loop passes each such batch through `combine_moves` before the guard and the
send, so a curve goes out as one twm per change. What twm does not carry (r, a, mode)
goes first, in its order: `r` first of all, since a change of style resets the board's
counters (A.4.8).

A batch is left as it is when folding it would change what the board is told: when it
does not end in a move, sets nothing twm carries besides `p`, holds anything but move
settings, leaves a value twm needs unknown, or is not a curve (r > 50, A.4.2; twm is for
curved moves); and when the twm would be longer than the guard's line
(command_guard.MAX_LINE_CHARS), which only a move written with more decimals than the
console's own would be.

`separate_moves` is the way back: a twm as the sets it stands for, for whatever keeps
moves in the thesis's form (a taught route, which then replays on any board).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from giraff_console.protocol.codec import TWM, TWM_SETTINGS, Command, Number, parse_number
from giraff_console.protocol.errors import CommandError
from giraff_console.robot.command_guard import MAX_LINE_CHARS, MAX_STRAIGHT_STYLE

# Settings a move uses that twm does not carry: sent as their own `set`s before it.
SEPARATE = ("r", "a", "mode")
# The value twm ends with (wire-facts); what it means is not documented.
TWM_END = 0


def combine_moves(commands: Sequence[Command], held: Mapping[str, str]) -> list[Command]:
    """`commands` with their move folded into one `set twm`, where it can be.

    `held` is what the board holds for its next move, as sent on the wire: settings the
    batch does not change are taken from it. A copy of `commands` comes back unchanged
    when the move cannot go out as a twm (see the module's docstring).
    """
    batch = list(commands)
    if not batch or batch[-1].kind != "set" or batch[-1].name != "p":
        return batch
    sets: dict[str, Number] = {}
    for command in batch[:-1]:
        if command.kind != "set" or command.name in sets:
            return batch
        if command.name not in SEPARATE and command.name not in TWM_SETTINGS:
            return batch
        assert not isinstance(command.value, tuple)  # only a twm has several
        assert command.value is not None
        sets[command.name] = command.value
    if not any(name in sets for name in TWM_SETTINGS):
        return batch  # a target renewed alone: `set p` is the shorter command
    target = batch[-1].value
    assert target is not None and not isinstance(target, tuple)
    values: list[Number] = []
    for name in TWM_SETTINGS[:-1]:
        value = sets.get(name, _held(held, name))
        if value is None:
            return batch
        values.append(value)
    style = sets.get("r", _held(held, "r"))
    if style is None or not style > MAX_STRAIGHT_STYLE:
        return batch  # straight or turning on the spot: twm is for curves
    try:
        twm = Command("set", TWM, (*values, target, TWM_END))
        if len(twm.text) > MAX_LINE_CHARS:
            return batch
    except CommandError:
        return batch
    return [*(command for command in batch[:-1] if command.name in SEPARATE), twm]


def separate_moves(command: Command) -> list[Command]:
    """A twm as the separate sets it stands for (vg, cdp, vgr, v, then p: the move
    last); any other command as it is."""
    if command.kind != "set" or command.name != TWM:
        return [command]
    return [Command("set", name, value)
            for name, value in zip(TWM_SETTINGS, command.values, strict=False)]  # fmt: skip


def _held(held: Mapping[str, str], name: str) -> Number | None:
    """A setting the board holds, as a number; None when it is unknown."""
    text = held.get(name)
    if text is None:
        return None
    try:
        return parse_number(text)
    except CommandError:
        return None
