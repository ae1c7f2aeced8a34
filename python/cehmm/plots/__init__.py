"""Figures of every result (matplotlib; ``pip install 'cehmm[plot]'``).

Every function returns a :class:`matplotlib.figure.Figure` built without pyplot (no GUI backend
is needed: ``fig.savefig("x.png")`` renders with Agg); matplotlib is imported when a function is
called, so this package imports without it, and a call without it raises an ``ImportError``
that says how to install it.

* runs: :func:`learning_curve` (also ``result.plot()``), :func:`read_history` (a history file
  checked line by line, at most :data:`MAX_HISTORY_BYTES`), and the reproduction's
  :func:`learning_curves` and :func:`summary_bars`;
* memory, for any world: :func:`memory_use` (states visited per level against time),
  :func:`decision_law` (heat maps of the decision per memory state and observation),
  :func:`memory_heatmap` (visits of (m₁, y) and (m₁, m₂));
* tabular worlds: :func:`policy_graph` (the controller as a graph; DOT from
  ``Policy.graph(form="dot")``);
* episodes: :func:`rollout` (also ``rollout.plot()``), :func:`animation` (also
  ``rollout.animate("episode.gif")``), :func:`trajectory` (a stretch of a typical
  target-tracking episode).

Example:
    >>> import cehmm, cehmm.plots
    >>> world = cehmm.TargetTracking(case=3)
    >>> policy = cehmm.Policy.uniform(world, [4, 4])
    >>> cehmm.plots.memory_use(policy, world).savefig("memory.png")  # doctest: +SKIP
"""

from .curves import learning_curve, learning_curves, summary_bars
from .graph import policy_graph
from .history import MAX_HISTORY_BYTES, read_history
from .memory import decision_law, memory_by_step, memory_heatmap, memory_usage, memory_use
from .tracking import animation, pick_episode, rollout, trajectory

__all__ = [
    "MAX_HISTORY_BYTES",
    "animation",
    "decision_law",
    "learning_curve",
    "learning_curves",
    "memory_by_step",
    "memory_heatmap",
    "memory_usage",
    "memory_use",
    "pick_episode",
    "policy_graph",
    "read_history",
    "rollout",
    "summary_bars",
    "trajectory",
]
