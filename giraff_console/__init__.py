"""giraff-console: operator console and board simulator for the Giraff telepresence robot."""

import serial

__version__ = "0.1.0"

# Teach pyserial the giraff-sim:// scheme, so that any code that opens ports by URL
# can reach the simulated board (design.md: extend pyserial through its URL handlers).
if "giraff_console.sim.urlhandler" not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append("giraff_console.sim.urlhandler")
