"""Scans in motion (numpy only): the rangefinder's clock, the path the robot drives, its
pose at every 2D scan and every beam, and the raw and deskewed clouds of each 3D scan.

    timing.py      when each beam is measured, where the head points then
    trajectory.py  the path (trail, waypoints, straight line) sampled at constant speed
    placements.py  the four-laser placement at every 2D scan, in batches of rays
    sweep.py       the rays of a run of 2D scans, cast, and their raw and deskewed clouds
"""
