"""``python -m emulator.esc.build``: compile the ESC's busiest modules with mypyc
(:func:`emulator.esc.compiled.main`; a module of its own, since importing :mod:`emulator.esc`
imports :mod:`emulator.esc.compiled`)."""

import sys

from emulator.esc.compiled import main

if __name__ == "__main__":
    sys.exit(main())
