"""``python -m jaxpg.sweep``: the sweep command line (``jaxpg.sweep.cli``)."""

import sys

from jaxpg.sweep.cli import main

sys.exit(main())
