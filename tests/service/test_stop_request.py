"""`giraff-console stop` in a hurry (issue 30, item 3): the two lines it writes by hand
are the very lines a console's Hello and Asked give (what it loads: tests/test_cli.py)."""

from __future__ import annotations

import pytest

from giraff_console.service import commands as c
from giraff_console.service.console_hello import Asked, Hello
from giraff_console.service.console_name import console_name
from giraff_console.service.stop_request import NUMBER, stop_lines
from giraff_console.service.transport import encode_line


@pytest.mark.parametrize(("shutdown", "request_"), [(False, c.Halt()), (True, c.Shutdown())])
def test_the_stop_says_what_a_console_would(shutdown: bool, request_: c.Request) -> None:
    said = encode_line(Hello(console_name("stop"), take=False)) + encode_line(
        Asked(NUMBER, request_)
    )
    assert stop_lines(shutdown) == said
