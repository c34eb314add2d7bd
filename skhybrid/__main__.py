"""``python -m skhybrid``: the same as the ``skhybrid`` command."""

import sys

from skhybrid.cli import main

sys.exit(main())
