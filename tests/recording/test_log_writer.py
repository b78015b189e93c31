"""The log writer: every line on disk at once, and a full disk stops it cleanly."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from giraff_console.recording.log_writer import LogWriter


def wait_for(condition, timeout=2.0) -> bool:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.005)
    return True


def test_each_line_is_in_the_file_before_the_writer_closes(tmp_path):
    path = tmp_path / "control.log"
    writer = LogWriter(path)
    writer.write("   0.000:[G] v: 0.30000")
    # Another reader sees it while the writer is still open: it was flushed.
    assert wait_for(lambda: path.read_text() == "   0.000:[G] v: 0.30000\n")
    writer.write("   0.100:[G] v: 0.30000")
    writer.close()
    assert path.read_text().count("\n") == 2 and writer.written == 2


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
def test_a_full_disk_stops_the_log_with_a_message(tmp_path):
    path = tmp_path / "control.log"
    os.symlink("/dev/full", path)  # every write fails with ENOSPC, as on a full disk
    messages: list[str] = []
    writer = LogWriter(path, messages.append)
    writer.write("   0.000:[G] v: 0.30000")
    assert wait_for(lambda: writer.error is not None)
    assert "No space left on device" in writer.error
    assert messages == [writer.error]
    writer.write("more")  # ignored, not raised
    writer.close()
