"""`wildscan drive`: the robot drives along a path while the head turns; every beam has its
own time and pose (docs/motion.md).

    request.py  what a drive asks for, checked before any work
    world.py    the world's triangles, its trail, the path, one crop around all of it
    run.py      run_drive: place the robot at every 2D scan, sweep, write
    files.py    the outputs: PLY clouds, SemanticKITTI, TUM, drive.json, staged and moved in place
    bags.py     the ROS 1 and ROS 2 bags: LaserScan, PointCloud2, tf, Odometry
"""

from .request import DriveRequest
from .run import DriveReport, Interrupted, run_drive

__all__ = ["DriveReport", "DriveRequest", "Interrupted", "run_drive"]
