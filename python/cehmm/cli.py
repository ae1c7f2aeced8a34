"""The ``cehmm`` console script: ``cehmm COMMAND [ARGS...]``.

The engine's command line (``optimize``, ``controller``, ``evaluate``, ``show``, ``optimum``,
``qlearn``, ``qlearn-eval``, ``run``) is the one the ``ceworld`` binary runs, compiled into the
package (no second copy of its options); ``plot``, ``reproduce`` and ``benchmarks`` are the
package's own (:mod:`cehmm.plots`, :mod:`cehmm.reproduce`, :mod:`cehmm.benchmarks`). ``cehmm
--help`` is the engine's, which lists the package's commands with its own.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import Any

from . import _core

#: The package's own commands (written in Python), with what they do, as the engine lists them
#: in ``cehmm --help`` (crates/ceworld/src/cli/help.rs, their one home).
PYTHON_COMMANDS: dict[str, str] = dict(_core.PACKAGE_COMMANDS)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs a command; returns the exit status."""
    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) >= 2 and args[0] == "help" and args[1] in PYTHON_COMMANDS:
        args = [args[1], "--help"]
    command, rest = (args[0], args[1:]) if args else ("", [])
    if command == "plot":
        return plot(rest)
    if command == "reproduce":
        from . import reproduce

        return reproduce.main(rest)
    if command == "benchmarks":
        from . import benchmarks

        return benchmarks.main(rest, prog="cehmm benchmarks")
    # The engine writes to the process's own stdout and stderr: what Python buffered goes first.
    # Without a command, it prints its help (every command, the package's too) and exits 2.
    sys.stdout.flush()
    sys.stderr.flush()
    return _core.cli(args)


#: What ``cehmm plot`` draws of a policy file (``--what``), by the function that draws it.
POLICY_FIGURES = {"graph": "policy_graph", "law": "decision_law", "memory": "memory_use"}


def plot(args: Sequence[str]) -> int:
    """``cehmm plot FILE... --out PNG``: learning curves of history files, or a figure of a
    policy file (its policy graph on a tabular world, else its decision law)."""
    import argparse

    parser = argparse.ArgumentParser(
        prog="cehmm plot",
        description=PYTHON_COMMANDS["plot"] + ": cehmm plot FILE... --out PNG",
        epilog="A .jsonl or .csv file is a history (several share one axes); a .json file a policy (one). "
        "A policy's default figure is its policy graph on a tabular world, else its decision law (of any world: "
        "one written in Python or a Gymnasium environment named by the spaces its file records).",
    )
    parser.add_argument("files", nargs="+", metavar="FILE", help="a history (.jsonl, .csv) or a policy file (.json)")
    parser.add_argument("--out", required=True, help="the figure (PNG, SVG, PDF: by its extension)")
    parser.add_argument(
        "--x", choices=["iteration", "seconds", "env_steps"], default="iteration", help="histories: the x axis"
    )
    parser.add_argument(
        "--what",
        choices=sorted(POLICY_FIGURES),
        help="a policy: its policy graph (tabular worlds), decision law, or memory use (rollouts of its world, "
        "one of the engine's)",
    )
    parser.add_argument("--prune", type=float, default=_core.GRAPH_PRUNE, help="--what graph: laws left out")
    parser.add_argument("--episodes", type=int, default=200, help="--what memory: rollouts")
    parser.add_argument("--force", action="store_true", help="replace --out when it exists")
    options = parser.parse_args(args)
    from pathlib import Path

    try:
        # The engine's rule: no output is the same file as an input (links followed).
        _core.check_distinct([("FILE", f) for f in options.files], [("--out", options.out)])
    except ValueError as e:
        print(f"cehmm plot: error: {e}", file=sys.stderr)
        return 2
    if Path(options.out).exists() and not options.force:
        print(f"cehmm plot: error: {options.out} exists (give --force to replace it)", file=sys.stderr)
        return 2
    try:
        figure = _figure_of(options)
        figure.savefig(options.out, dpi=120)
    except (OSError, ValueError, TypeError, ImportError) as e:
        print(f"cehmm plot: error: {e}", file=sys.stderr)
        return 2
    print(f"saved {options.out}")
    return 0


def _figure_of(options: Any) -> Any:
    """The figure ``cehmm plot`` was asked for."""
    from pathlib import Path

    from . import plots
    from .policy import Policy
    from .world import world_title

    policies = [f for f in options.files if Path(f).suffix == ".json"]
    if not policies:
        if options.what is not None:
            raise _core.InvalidArgumentError(f"invalid --what: {options.what} (expected a policy file, .json)")
        return plots.learning_curve(*options.files, x=options.x)
    if len(options.files) > 1:
        raise _core.InvalidArgumentError(
            f"invalid files: {' '.join(options.files)} (expected history files, or one policy file)"
        )
    policy = Policy.load(policies[0])
    what = options.what or ("graph" if policy.world.get("name") == "pomdp" else "law")
    title = f"{policies[0]}: a policy of {world_title(policy.world) or 'its world'} (levels {policy.levels})"
    if what == "graph":
        return plots.policy_graph(policy, prune=options.prune, title=title)
    if what == "memory":
        return plots.memory_use(policy, episodes=options.episodes, title=title)
    return plots.decision_law(policy, title=title)


if __name__ == "__main__":
    sys.exit(main())
