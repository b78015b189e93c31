"""Every command the README and the docs show runs as written (issue 26, the operator's
first day): it parses, and the rooms, patrols and files it names are there.

The README's `patrol night` once named a patrol that was never shipped; these checks
would have caught it. They do not drive the robot: parsing and looking up is enough to
catch a renamed option, a missing example or a room that is not in the example plan.
Driving each example is left to the tests of each command (and to a person with tmux).
"""

from __future__ import annotations

import argparse
import re
import shlex
from dataclasses import dataclass
from pathlib import Path

import pytest

from giraff_console.cli.main import build_parser
from giraff_console.data_folders import example_floorplan, example_routes
from giraff_console.missions.docking import DOCK
from giraff_console.missions.names import patrol_file
from giraff_console.missions.patrol import load_patrol
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.service.commands import TYPED

ROOT = Path(__file__).resolve().parent.parent
# What a person reads: the README, the guides in docs/ and the format descriptions.
DOCUMENTS = [
    ROOT / "README.md",
    *sorted((ROOT / "docs").glob("*.md")),
    ROOT / "routes" / "README.md",
    ROOT / "floorplans" / "README.md",
    ROOT / "recordings" / "README.md",
]
PLAN = load_floorplan(example_floorplan())
# Placeholders the docs write in capitals (ROOM, FILE, DIR, PTY), and synopses with
# optional parts; neither is an example to run.
PLACEHOLDER = re.compile(r"^[A-Z][A-Z0-9_.]*$")
SYNOPSIS = ("[", "...", "|", "<")


@dataclass(frozen=True)
class Example:
    where: str  # file:line, for the failure
    args: tuple[str, ...]  # after `giraff-console`
    # In a shell block, to be typed as it is; else inline in the text, where it may only
    # mention a command (`giraff-console floorplan landmarks` places them for you).
    block: bool

    def __str__(self) -> str:
        return f"{self.where}: giraff-console {shlex.join(self.args)}"


def shell_lines(text: str) -> list[tuple[int, str]]:
    """The lines of the ```sh blocks, continuations joined, with their line numbers."""
    lines, block, pending = [], False, ""
    for number, line in enumerate(text.splitlines(), 1):
        fence = line.strip().startswith("```")
        if fence:
            block = line.strip() in ("```sh", "```bash", "```console")
            pending = ""
            continue
        if not block:
            continue
        line = pending + line.strip()
        if line.endswith("\\"):
            pending = line[:-1] + " "
            continue
        pending = ""
        lines.append((number, line))
    return lines


def examples(path: Path) -> list[Example]:
    """Each `giraff-console ...` in `path`: in a shell block, or inline in backticks."""
    text = path.read_text()
    found = []
    places = [(number, line, True) for number, line in shell_lines(text)]
    for number, line in enumerate(text.splitlines(), 1):
        places += [(number, span, False) for span in re.findall(r"`(giraff-console[^`]*)`", line)]
    for number, line, block in places:
        start = line.find("giraff-console")
        # A unit file's ExecStart, or a log line the docs quote: not a command.
        if start < 0 or line[start:].startswith("giraff-console:") or "ExecStart" in line:
            continue
        command = line[start:]
        # `$(giraff-console sim --modem-shim)`: the command inside the substitution.
        if line[:start].endswith("$("):
            command = command.split(")", 1)[0]
        words = shlex.split(command, comments=True)
        if words[0] != "giraff-console" or any(s in word for word in words for s in SYNOPSIS):
            continue
        args = words[1:]
        if args and args[-1] in ("&", "|"):
            args = args[:-1]
        if "|" in args:
            args = args[: args.index("|")]
        if "--help" in args or "--version" in args:
            continue  # argparse prints and exits: nothing to look up
        found.append(Example(f"{path.relative_to(ROOT)}:{number}", tuple(args), block))
    return found


EXAMPLES = [example for path in DOCUMENTS for example in examples(path)]


def parse(example: Example) -> argparse.Namespace | None:
    """The example's arguments as the command line reads them; None for a mention of a
    command in the text that leaves out what it needs."""
    parser = build_parser()
    try:
        return parser.parse_args(list(example.args))
    except SystemExit as exit:  # argparse's way of saying no
        if not example.block:
            return None
        raise AssertionError(f"{example} does not parse (exit {exit.code})") from None


def test_the_docs_have_examples_to_check():
    """The extraction finds them: a change of fence or wording must not empty the list."""
    assert sum(example.block for example in EXAMPLES) >= 40
    shown = {example.args for example in EXAMPLES if example.block}
    assert ("patrol", "night", "--sim", "--sim-speed", "inf", "--json") in shown
    assert ("sim", "--modem-shim") in shown
    assert any(args[:1] == ("serve",) and "--floorplan" in args for args in shown)


@pytest.mark.parametrize("example", EXAMPLES, ids=str)
def test_every_example_command_parses(example, capsys):
    parse(example)
    assert not capsys.readouterr().out  # nothing printed: no --help by another name


def rooms_named(args: argparse.Namespace) -> list[str]:
    """The rooms of the example plan a command names, where it plans on the example."""
    if getattr(args, "floorplan", None) not in (None, example_floorplan()):
        return []  # the operator's own building: its rooms are theirs
    named = []
    if args.command == "go":
        named.append(args.room)
    elif args.command == "plan":
        named += [args.origin, args.destination]
    for option in ("at", "sim_start"):
        value = getattr(args, option, None)
        if isinstance(value, str):
            named.append(value.split(":", 1)[0])
    return [room for room in named if room and not PLACEHOLDER.match(room)]


@pytest.mark.parametrize("example", EXAMPLES, ids=str)
def test_the_rooms_and_patrols_an_example_names_are_there(example, tmp_path):
    """A room in the example floor plan; a patrol in an empty routes folder (a fresh
    install's), so among the examples that ship with the package, with its rooms in the
    example plan and the routes it drives beside it."""
    args = parse(example)
    if args is None:
        return  # a mention, not a command to run
    for room in rooms_named(args):
        assert room in PLAN.rooms or room == DOCK, f"{example}: no room {room} in the example"
    if args.command == "patrol" and not PLACEHOLDER.match(args.name):
        path = patrol_file(args.name, (tmp_path, example_routes()))
        assert path.is_file(), f"{example}: no patrol {args.name} ships with the console"
        patrol = load_patrol(path)
        for stop in patrol.stops:
            if stop.room is not None:
                assert stop.room in PLAN.rooms or stop.room == DOCK, f"{example}: {stop}"
            else:
                assert (path.parent / f"{stop.route}.yaml").is_file(), f"{example}: {stop}"
    if args.command == "replay" and args.session.parts[0] == "recordings":
        # "in a clone": the committed sample.
        assert (ROOT / args.session).is_dir(), f"{example}: no {args.session} in a clone"


def typed_commands(path: Path, header: str) -> list[str]:
    """The first words of the commands in the first column of the table under `header`
    in `path`: `go ROOM`, `close DOOR`, `open DOOR` give go, close, open."""
    table = path.read_text().split(header, 1)[1].split("\n\n", 1)[0]
    cells = [line.split("|")[1] for line in table.splitlines() if line.startswith("|")]
    return [word for cell in cells for word in re.findall(r"`([a-z][a-z-]*)[^`]*`", cell)]


@pytest.mark.parametrize(
    ("path", "header"),
    [("README.md", "| command | does |"), ("routes/README.md", "| Command | What it does |")],
)
def test_the_console_commands_in_the_tables_are_commands_it_knows(path, header):
    """`go ROOM`, `replay-route NAME`, ...: words the command line (Enter) takes."""
    known = {typed.word for typed in TYPED}
    words = typed_commands(ROOT / path, header)
    assert len(words) >= 8
    assert sorted(set(words) - known) == []
