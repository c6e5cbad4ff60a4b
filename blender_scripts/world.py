"""Build a world with a real Blender: `blender -b -P blender_scripts/world.py -- ARGS`.

ARGS are those of `wildscan world`. Files saved by Blender 3.4 this way open in
every Blender from 3.4 to 5.0 (files saved by 5.0 do not open in 3.4).
"""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "addon"))

from wildscan.app.interrupts import defer_until_dispatch  # noqa: E402

defer_until_dispatch()  # before the slow imports: Blender's own handler ignores the first Ctrl-C

from wildscan.cli import blender_main  # noqa: E402

sys.exit(blender_main("world"))
