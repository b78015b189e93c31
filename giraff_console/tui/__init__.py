"""The Textual console: a thin front end over the control loop (design.md)."""
