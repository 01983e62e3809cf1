"""Ensembles and parameter sweeps: a grid of runs on dask.distributed -> one Parquet table
-> statistics.  Beside the CLI; calls the engine; dask is imported only here."""

from .spec import SweepSpec, Task, parse_alphas, parse_choices, parse_segments, run_id

__all__ = ["SweepSpec", "Task", "parse_alphas", "parse_choices", "parse_segments", "run_id"]
