"""pyserial's entry point for `giraff-lidar://` URLs (the file name must match the scheme)."""

from giraff_console.sim.lidar_port import Serial

__all__ = ["Serial"]
