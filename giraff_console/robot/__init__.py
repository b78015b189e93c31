"""The robot as the console sees it, built on the link."""

from giraff_console.robot.odometry import Odometry, Pose

__all__ = ["Odometry", "Pose"]
