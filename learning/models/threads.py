"""The torch thread count at planning time: what the library chooses, restored for the caller afterwards.

torch's default (one thread per core) is slow for the small passes a sampler makes while planning, and
worse when several planners run side by side: on a 2-core machine a 256 x 256 route-encoder query took
several times longer at the default than at one thread. Samplers that run torch while planning (the
route encoder's ``predict``, ``SB3Sampler``'s policy) run it inside ``planning_threads``: at ``threads``
if given, else ``SAMPLERGYM_TORCH_THREADS`` if set, else one, and the caller's setting comes back after.
A training script of one's own should call ``torch.set_num_threads`` itself (one per process when
several run at once, the number of cores for one process alone).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager

import torch

from planners.base.fileio import InputError

ENV = "SAMPLERGYM_TORCH_THREADS"


def planning_thread_count(threads: int | None = None) -> int:
    """``threads`` if given, else ``SAMPLERGYM_TORCH_THREADS``, else 1; ``InputError`` naming a bad value."""
    source, value = ("threads", threads) if threads is not None else (ENV, os.environ.get(ENV))
    if value is None or value == "":
        return 1
    try:
        n = int(value) if not isinstance(value, bool) else -1
    except (TypeError, ValueError):
        n = -1
    if isinstance(value, float) or n < 1 or n > 1024:
        raise InputError(f"{source} = {value!r}: expected a whole number of torch threads from 1 to 1024")
    return n


@contextmanager
def planning_threads(threads: int | None = None) -> Iterator[int]:
    """Run the block at the planning thread count (``planning_thread_count``), then restore the caller's."""
    n = planning_thread_count(threads)
    before = torch.get_num_threads()
    if n != before:
        torch.set_num_threads(n)
    try:
        yield n
    finally:
        if torch.get_num_threads() != before:
            torch.set_num_threads(before)
