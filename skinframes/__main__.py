"""``python -m skinframes`` runs the command line.

An entry point, not library code: the one module of ``skinframes`` that imports ``skinframes_cli``
(the package above ``emulator``), so the old way to start the command keeps working. No module of the
library imports it; ``tests/test_layering.py`` checks both.
"""

import sys

from skinframes_cli import main

sys.exit(main())
