"""The robot as one typed surface: commands in, one event stream out (issue 15)."""
