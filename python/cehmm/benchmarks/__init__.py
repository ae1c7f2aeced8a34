"""The benchmark runner: CE controllers on every Cassandra ``.pomdp`` file of ``data/pomdp/``, evaluated
exactly and set against SARSOP's bounds, in ``docs/benchmarks.md``.

Each (file, controller) pair is a job: a controller of :data:`CONTROLLERS` learned by
:func:`cehmm.optimize` under a time limit, on episodes of H steps (:func:`~cehmm.benchmarks.config.horizon`),
then its exact value (infinite-horizon for γ < 1, at H for γ = 1), whether it is deterministic and its
number of nodes. A run rewrites ``OUT/data/benchmarks.jsonl`` (one line per file, then one per finished
job, each with the command, settings, machine and commit) and renders ``OUT/benchmarks.md`` from it alone,
so ``--report-only`` rebuilds the page byte for byte. The first Ctrl-C lets the running job finish and stops
(the report is still written; exit 130), a second one abandons it.

Usage::

    python -m cehmm.benchmarks                       # every file × every controller, 8 s per job
    python -m cehmm.benchmarks --quick               # 5 small files × 2 controllers, 2 s per job
    python -m cehmm.benchmarks --files 'tiger*' --controllers '2 nodes' --time-limit 4 --out /tmp/b
    python -m cehmm.benchmarks --report-only [--check]

The package, one concept a module (each imports only those above it):

- :mod:`~cehmm.benchmarks.config`: controllers, settings, the quick subset, the horizon rule, paths;
- :mod:`~cehmm.benchmarks.files`: the files, what each declares, SARSOP's bounds, comparability notes;
- :mod:`~cehmm.benchmarks.job`: one job and its record;
- :mod:`~cehmm.benchmarks.run`: the jobs, serially or in worker processes, progress lines, Ctrl-C;
- :mod:`~cehmm.benchmarks.summary`: best controllers, ratios, the "what this shows" paragraph;
- :mod:`~cehmm.benchmarks.anchors_report`: the page's section on the controller search beside SARSOP and PAYNT;
- :mod:`~cehmm.benchmarks.report`: the markdown page (that section first, then the grid);
- :mod:`~cehmm.benchmarks.cli`: the command line (:func:`main`);
- :mod:`~cehmm.benchmarks.anchors`: its own command, ``python -m cehmm.benchmarks.anchors``: every discounted model
  with a reference searched with the controller search's defaults (``--time-limit 600`` on one core).
"""

from __future__ import annotations

from .cli import build_parser, main, select_controllers
from .config import CONTROLLERS, QUICK_CONTROLLERS, QUICK_FILES, default_settings, horizon
from .files import comparability, file_facts, find_files, parse_sarsop, scan_preamble
from .job import run_job
from .report import render_report
from .run import run_jobs

__all__ = [
    "CONTROLLERS",
    "QUICK_CONTROLLERS",
    "QUICK_FILES",
    "build_parser",
    "comparability",
    "default_settings",
    "file_facts",
    "find_files",
    "horizon",
    "main",
    "parse_sarsop",
    "render_report",
    "run_job",
    "run_jobs",
    "scan_preamble",
    "select_controllers",
]
