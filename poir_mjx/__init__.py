"""poir-mjx: POIR (return-to-distribution planning) evaluated at scale on robosuite tasks stepped in MJX."""

from poir_mjx import quiet as _quiet

_quiet.install()
