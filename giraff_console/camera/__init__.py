"""Camera: frame sources, feature processors, the terminal view and video recording."""
