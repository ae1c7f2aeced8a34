"""Reproduces the paper's results table (model §5, Q-learning rows excepted) and writes a report.

Every row of the table is run over several seeds; each (row, seed, settings) job optimises a
policy, evaluates it on fresh episodes and appends one line to a JSON-lines file (the data, by
default ``docs/data/reproduce.jsonl``, committed), so that a run can be stopped (Ctrl-C) and
resumed. A job is identified by its row, seed, settings label *and* the exact keyword arguments
it ran with: a preset whose settings change runs again. From the data come ``results.json``,
``results.csv``, a markdown report (``docs/results.md`` by default) and its figures
(``docs/img/``); ``--report-only`` rebuilds them from the data alone (a figure that needs a
policy no longer on disk replays its job, which is deterministic).

Usage::

    python -m cehmm.reproduce                      # every row, 5 seeds, the paper's settings
    cehmm reproduce --seeds 3 --jobs 2             # 2 worker processes of 1 thread each
    cehmm reproduce --rows 'c3-*-strong'           # a subset of rows (ids or glob patterns)
    cehmm reproduce --set smoothing=0.7            # any optimize() keyword, for every row
    cehmm reproduce --report-only                  # rebuild the outputs from the JSONL only
    cehmm reproduce --report-only --check          # exit 1 if docs/results.md is not what the data gives
    cehmm reproduce --quick --out-dir /tmp/q       # a seconds-long smoke run

Rows (:data:`ROWS`) and settings presets (:data:`SETTINGS`) are plain data: a new preset is a new
entry of :data:`SETTINGS` (or a JSON file given to ``--settings``), mapping ``"*"`` (every row)
and row ids to keyword arguments of :func:`cehmm.optimize`, passed through unchanged.

The package, one concept a module (each imports only those above it in this list):

- :mod:`~cehmm.reproduce.records`: the JSON-lines data (its record keys, reading and appending);
- :mod:`~cehmm.reproduce.jobs`: job identity (rows, presets, the keyword arguments of a job, its name);
- :mod:`~cehmm.reproduce.machine`: where a job runs (machine, git commit, load);
- :mod:`~cehmm.reproduce.worker`: one job, in this process or a worker, and its Ctrl-C;
- :mod:`~cehmm.reproduce.text`: short text forms (a duration, a row's model);
- :mod:`~cehmm.reproduce.progress`: one progress line per finished job, with an ETA;
- :mod:`~cehmm.reproduce.run`: running the jobs, serially or in a pool of worker processes;
- :mod:`~cehmm.reproduce.summary`: each row's records aggregated over seeds, against the paper;
- :mod:`~cehmm.reproduce.tables`: ``results.json`` and ``results.csv``;
- :mod:`~cehmm.reproduce.report`: the markdown report;
- :mod:`~cehmm.reproduce.figures`: the report's figures;
- :mod:`~cehmm.reproduce.cli`: the command line (:func:`main`).
"""

from __future__ import annotations

from ..paper_table import PAPER_BEST, QUICK_ROWS, QUICK_SEEDS, ROWS, SETTINGS
from .cli import build_parser, main, regenerate_command
from .figures import job_policy, make_figures, planned_figures
from .jobs import (
    expected_kwargs,
    job_kwargs,
    job_stem,
    kwargs_key,
    load_preset,
    parse_set,
    rows_by_id,
    select_rows,
    settings_label,
)
from .machine import machine_info, source_commit
from .records import DEFAULT_DATA, HISTORY_KEYS, JSONL_NAME, RECORD_KEYS, append_record, compact_history, read_records
from .report import render_report
from .run import run_jobs
from .summary import aggregate, run_stats, status_text
from .tables import CSV_FIELDS, write_tables
from .text import model_text
from .worker import run_job

__all__ = [
    "CSV_FIELDS",
    "DEFAULT_DATA",
    "HISTORY_KEYS",
    "JSONL_NAME",
    "PAPER_BEST",
    "QUICK_ROWS",
    "QUICK_SEEDS",
    "RECORD_KEYS",
    "ROWS",
    "SETTINGS",
    "aggregate",
    "append_record",
    "build_parser",
    "compact_history",
    "expected_kwargs",
    "job_kwargs",
    "job_policy",
    "job_stem",
    "kwargs_key",
    "load_preset",
    "machine_info",
    "main",
    "make_figures",
    "model_text",
    "parse_set",
    "planned_figures",
    "read_records",
    "regenerate_command",
    "render_report",
    "rows_by_id",
    "run_job",
    "run_jobs",
    "run_stats",
    "select_rows",
    "settings_label",
    "source_commit",
    "status_text",
    "write_tables",
]
