"""The ``cehmm`` console script: ``cehmm COMMAND [ARGS...]``.

The engine's command line (``optimize``, ``evaluate``, ``show``, ``controller``, ``optimum``,
``qlearn``, ``qlearn-eval``) is the one the ``ceworld`` binary runs, compiled into the package
(no second copy of its options); ``reproduce`` and ``benchmarks`` are the package's own
(:mod:`cehmm.reproduce`, :mod:`cehmm.benchmarks`).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from . import _core

#: The package's own commands (written in Python), with what they do.
PYTHON_COMMANDS = {
    "plot": "draw history files (--history FILE.jsonl or .csv) as learning curves: cehmm plot H... --out PNG",
    "reproduce": "reproduce the paper's results table (model §5) and write the report",
    "benchmarks": "learn controllers for every .pomdp file of data/pomdp and write docs/benchmarks.md",
}

USAGE = (
    "usage: cehmm COMMAND [ARGS...]   (cehmm COMMAND --help for its options)\n\n"
    "commands of the engine: optimize, evaluate, show, controller, optimum, qlearn, qlearn-eval\n"
    "  (cehmm --help lists them with what they do)\n"
    "commands of the package:\n" + "".join(f"  {name:<11} {what}\n" for name, what in PYTHON_COMMANDS.items())
)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs a command; returns the exit status."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args:
        print(USAGE, end="", file=sys.stderr)
        return 2
    command, rest = args[0], args[1:]
    if command == "plot":
        return plot(rest)
    if command == "reproduce":
        from . import reproduce

        return reproduce.main(rest)
    if command == "benchmarks":
        from . import benchmarks

        return benchmarks.main(rest)
    # The engine writes to the process's own stdout and stderr: what Python buffered goes first.
    sys.stdout.flush()
    sys.stderr.flush()
    status = _core.cli(args)
    if command in ("-h", "--help", "help"):
        print("\n" + USAGE, end="")
    return status


def plot(args: Sequence[str]) -> int:
    """``cehmm plot HISTORY... --out PNG [--x seconds]``: the learning curves of history files."""
    import argparse

    parser = argparse.ArgumentParser(prog="cehmm plot", description=PYTHON_COMMANDS["plot"])
    parser.add_argument("histories", nargs="+", metavar="HISTORY", help="a .jsonl or .csv history file")
    parser.add_argument("--out", required=True, help="the figure (PNG, SVG, PDF: by its extension)")
    parser.add_argument("--x", choices=["iteration", "seconds"], default="iteration")
    parser.add_argument("--force", action="store_true", help="replace --out when it exists")
    options = parser.parse_args(args)
    from pathlib import Path

    from .plots import learning_curve

    if Path(options.out).exists() and not options.force:
        print(f"cehmm plot: error: {options.out} exists (give --force to replace it)", file=sys.stderr)
        return 2
    try:
        figure = learning_curve(*options.histories, x=options.x)
    except (OSError, ValueError, TypeError, ImportError) as e:
        print(f"cehmm plot: error: {e}", file=sys.stderr)
        return 2
    figure.savefig(options.out, dpi=120)
    print(f"saved {options.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
