"""The realistic sensor model: the beam footprint and its sub-rays, echoes, intensity (numpy only)."""
