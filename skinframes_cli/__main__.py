"""``python -m skinframes_cli`` runs the command line (as ``skinframes`` and ``python -m skinframes``)."""

import sys

from skinframes_cli import main

sys.exit(main())
