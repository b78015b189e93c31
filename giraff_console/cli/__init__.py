"""The `giraff-console` command line: the parser and which command runs (main.py), each
command in its own module beside it. Nothing is imported here, so that `giraff-console
stop` can load its own module alone (stop.py)."""
