"""``python -m clients.report``: the same as ``riverbridge report``."""

import sys

from clients.report.cli import main

sys.exit(main())
