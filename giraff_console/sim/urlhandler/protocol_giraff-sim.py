"""pyserial's entry point for `giraff-sim://` URLs (the file name must match the scheme)."""

from giraff_console.sim.serial_port import Serial

__all__ = ["Serial"]
