"""``python -m jaxpg.sweep``: the sweep command line (``jaxpg.sweep.cli``)."""

import sys

from jaxpg.sweep.cli import main

if __name__ == "__main__":
    sys.exit(main())
