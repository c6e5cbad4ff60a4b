"""Frames and rotations: sensor, leveled and world frames, Eq. 2, rotation vectors, reach (numpy only)."""
