"""Numpy-only core of WildScan. Nothing under this package may import bpy.

Grouped by meaning (docs/architecture.md "Layers"; tests/test_architecture.py keeps the tiers):

    root        the contracts everything reads: classes, errors, checks, rng, hits, backend,
                placement, pointcloud, posesampler, scan, label schemes and class weights
    detmath/    deterministic elementwise math
    sensors/    devices as data, scan settings and their per-device limits, beams, noise
    spatial/    frames, Eq. 2 leveling, rotation vectors, reach far from the origin
    runtime/    how a command runs: cast threads, freed memory, signals, cast clock, test pauses
    world/      the world planner
    effects/    the medium and scene effects (weather, cover, wind)
    truth/      ground truth a real dataset cannot have (height above ground, bird's-eye
                grids, traversability) and the open-ground and open-sky lookups behind it
    realism/    the realistic sensor model (footprint, coarse-to-fine, echoes, intensity)
    motion/     scans in motion (timing, trajectories, batched placement, sweeps)
    io/         files: the format table, PLY, LAS, SemanticKITTI (and its projection and
                range images), TUM, waypoints, ROS bags
"""
