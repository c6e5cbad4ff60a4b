"""Scan from a real Blender: `blender -b [world.blend] -P blender_scripts/scan.py -- ARGS`.

ARGS are those of `wildscan scan`. Without --world or --seed it scans the file
Blender was opened with, which is how a user scans a scene of their own.
"""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "addon"))

from wildscan.app.interrupts import defer_until_dispatch  # noqa: E402

defer_until_dispatch()  # before the slow imports: Blender's own handler ignores the first Ctrl-C

from wildscan.cli import blender_main  # noqa: E402

sys.exit(blender_main("scan"))
