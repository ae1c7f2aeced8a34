"""``python -m cehmm.benchmarks``: the command line of :mod:`cehmm.benchmarks.cli`."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
