"""`giraff-console export SESSION OUT.mcap`: a recorded session as MCAP, for Foxglove."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

# Only what the parser needs is imported here: every command, `--version` and `--help`
# included, pays for these before it reads its arguments. What a command needs to run
# (numpy, OpenCV, scipy, the planner, the robot, Textual) is imported by the command,
# when it runs (issue 26, item 6; tests/test_cli.py keeps it so).
from giraff_console.cli.exit_codes import EXIT_USAGE

if TYPE_CHECKING:
    pass


def add_export_parser(commands: argparse._SubParsersAction) -> None:
    export = commands.add_parser(
        "export",
        help="export a recorded session to MCAP, for Foxglove",
        description="Write SESSION's controller transcript, odometry pose, the pose "
        "filter's estimate with its covariance (sessions recorded with the filter) and JPEG "
        "camera frames to OUT as MCAP channels (/controller, /pose, /pose_estimate, /camera) "
        "with JSON schemas. /pose is the odometry's (frame odom); /pose_estimate is "
        "giraff.PoseWithCovarianceInFrame (frame map): a foxglove.PoseInFrame with a "
        "row-major 6x6 covariance over x, y, z, roll, pitch, yaw, in which z, roll and pitch "
        "are 0. See recordings/README.md.",
    )
    export.add_argument("session", type=Path, metavar="SESSION")
    export.add_argument("out", type=Path, metavar="OUT.mcap")


def run_export(args: argparse.Namespace) -> int:
    """A recorded session as an MCAP file."""
    from giraff_console.recording.mcap_export import export_session
    from giraff_console.recording.playback import open_log
    from giraff_console.recording.session import SessionError, SessionStart, read_meta
    from giraff_console.robot.replay import replay_poses

    try:
        _, log = open_log(args.session)
        meta = read_meta(args.session) if args.session.is_dir() else {}
        poses = replay_poses(log, SessionStart.from_meta(meta))
        summary = export_session(args.session, args.out, poses)
    except SessionError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    for problem in summary.problems:
        print(f"giraff-console: {problem}", file=sys.stderr)
    counts = ", ".join(f"{topic} {count}" for topic, count in summary.channels.items())
    print(f"{args.out}: {counts}")
    return 0
