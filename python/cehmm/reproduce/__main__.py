"""``python -m cehmm.reproduce``: the command line of :mod:`cehmm.reproduce.cli`."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
