import sys

from clients.linkemu.cli import main

sys.exit(main())
