"""``python -m flatland_ma.cli ARGS``: the ``flatland-ma`` script."""

import sys

from flatland_ma.cli.commands import main

sys.exit(main())
