"""The wire's one error. Apart from wire.py, whose rules for every type take a stop's
start 0.03-0.05 s to load, so that the transport can carry lines without them: `giraff-
console stop` writes its own (stop_request.py, issue 30)."""


class WireError(Exception):
    """A value that cannot be put on the wire, or wire data that cannot be built."""
