"""The comparison of samplers on held-out maps: protocol and splits, runs, tuning, tables and plots."""

from learning.evaluation.comparison import worker_init

__all__ = ["worker_init"]
