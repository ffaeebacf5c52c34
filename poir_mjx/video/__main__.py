"""``python -m poir_mjx.video ...`` is ``python -m poir_mjx.cli video ...`` (make video)."""

import sys

from poir_mjx.cli import main

sys.exit(main(["video", *sys.argv[1:]]))
