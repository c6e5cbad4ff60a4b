"""Ground truth a real dataset cannot have (numpy only): height above ground, bird's-eye
grids, traversability, and the open-ground and open-sky lookups that speed them up."""
