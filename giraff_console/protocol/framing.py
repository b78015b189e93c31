"""Line framing of the board's serial protocol (Appendix A.3, wire-facts "Serial line")."""

from __future__ import annotations

BAUD_RATE = 115200
# 8N1: a start bit, eight data bits and a stop bit carry each byte.
BITS_PER_BYTE = 10
BYTE_TIME_S = BITS_PER_BYTE / BAUD_RATE

# Commands end with CR only; replies end with CR LF (wire-facts).
COMMAND_END = b"\r"
LINE_END = b"\r\n"
PROMPT = "OK >"
BANNER_PREFIX = "# Giraf"
# Some boards print this before the banner (A.3); it carries no meaning.
CALIBRATION_LINE = "Ca>"


def is_prompt(line: str) -> bool:
    """True for the prompt that closes every exchange.

    The manufacturer's documentation writes it `OK>`, real boards send `OK >`; noise may
    precede it on the same line, so only the end of the line is checked.
    """
    stripped = line.rstrip()
    return stripped.endswith(PROMPT) or stripped.endswith("OK>")


def is_banner(line: str) -> bool:
    """True for the version line a board prints when it powers up."""
    return BANNER_PREFIX in line


def banner_version(line: str) -> str:
    """The text after `# Giraf` in a banner, for example `1.1.112p, 2011-02-20`."""
    return line.split(BANNER_PREFIX, 1)[1].strip()
