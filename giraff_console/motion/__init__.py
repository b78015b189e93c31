"""From a planned path to motion on the board: shaping, speed profiles, execution (§2.7)."""
