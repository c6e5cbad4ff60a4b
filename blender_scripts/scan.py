"""Scan from a real Blender: `blender -b [world.blend] -P blender_scripts/scan.py -- ARGS`.

ARGS are those of `wildscan scan`. Without --world or --seed it scans the file
Blender was opened with, which is how a user scans a scene of their own.
"""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "addon"))

from wildscan.cli import blender_main  # noqa: E402

sys.exit(blender_main("scan"))
