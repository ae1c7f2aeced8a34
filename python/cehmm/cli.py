"""The ``cehmm`` console script: ``cehmm SUBCOMMAND [ARGS...]``.

Subcommands:
    reproduce   run the paper's results table and write the report (:mod:`cehmm.reproduce`)
    benchmarks  CE controllers on every ``.pomdp`` file, against SARSOP (:mod:`cehmm.benchmarks`)
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

USAGE = """usage: cehmm SUBCOMMAND [ARGS...]

subcommands:
  reproduce   reproduce the paper's results table (model §5) and write the report
              (cehmm reproduce --help for its options)
  benchmarks  learn controllers for every .pomdp file of data/pomdp and write
              docs/benchmarks.md (cehmm benchmarks --help for its options)
"""


def main(argv: Sequence[str] | None = None) -> int:
    """Dispatches to a subcommand's ``main``; returns the exit status."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in ("-h", "--help", "help"):
        print(USAGE, end="")
        return 0 if args else 2
    command, rest = args[0], args[1:]
    if command == "reproduce":
        from . import reproduce

        return reproduce.main(rest)
    if command == "benchmarks":
        from . import benchmarks

        return benchmarks.main(rest)
    print(f"cehmm: unknown subcommand {command!r}\n\n{USAGE}", end="", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
