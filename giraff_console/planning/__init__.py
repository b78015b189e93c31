"""Route planning: floor plans, the room graph (A*), grids and D* Lite (§2.6.2, §2.6.4)."""
