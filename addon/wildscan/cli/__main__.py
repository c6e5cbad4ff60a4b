"""`python -m wildscan.cli …` is `wildscan …`."""

import sys

from . import main

sys.exit(main())
