"""``python -m poir_mjx.cli``."""

import sys

from poir_mjx.cli import main

sys.exit(main())
