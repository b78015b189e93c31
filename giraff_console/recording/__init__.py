"""Sessions on disk: recording the board's traffic and the camera, and playing them back."""
