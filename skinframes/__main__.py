"""``python -m skinframes`` runs the command line."""

import sys

from skinframes.cli import main

sys.exit(main())
