"""The committed sample session: it plays whole, and exports to MCAP from the command line."""

from __future__ import annotations

from pathlib import Path

from mcap.reader import make_reader

from giraff_console.cli.main import main
from giraff_console.recording.control_log import read_log
from giraff_console.recording.playback import frame_times

SAMPLE = Path(__file__).resolve().parents[2] / "recordings" / "sample"


def test_the_sample_session_reads_without_a_problem():
    log = read_log(SAMPLE / "control.log")
    assert log.problems == [] and log.duration > 5
    assert len(frame_times(SAMPLE, log)) > 50


def test_export_writes_the_three_channels_with_a_message_per_poll_line_and_frame(tmp_path, capsys):
    out = tmp_path / "sample.mcap"
    assert main(["export", str(SAMPLE), str(out)]) == 0
    log = read_log(SAMPLE / "control.log")
    polls = sum(entry.frame_marker for entry in log.entries)
    counts: dict[str, int] = {}
    with out.open("rb") as file:
        reader = make_reader(file)
        summary = reader.get_summary()
        assert summary is not None
        topics = {channel.topic: channel for channel in summary.channels.values()}
        for _, channel, _ in reader.iter_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
    assert set(topics) == {"/pose", "/controller", "/camera"}
    assert counts["/controller"] == len(log.entries)
    assert counts["/pose"] == polls
    assert counts["/camera"] == len(frame_times(SAMPLE, log))
    assert f"/controller {len(log.entries)}" in capsys.readouterr().out


def test_export_of_a_missing_session_is_a_clear_error(tmp_path, capsys):
    assert main(["export", str(tmp_path / "nothing"), str(tmp_path / "x.mcap")]) == 2
    assert "no session log at" in capsys.readouterr().err
    assert not (tmp_path / "x.mcap").exists()
