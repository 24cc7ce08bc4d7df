"""Restarts: a planner run cut short and begun again on a fresh seed, by Luby's universal sequence.

A tree planner guided by a sampler can grow into a trap: most runs solve soon and the rest stall for a long
time (heavy-tailed run times; Wedge and Branicky, "On heavy-tailed runtimes and restarts in rapidly-exploring
random trees", 2008). Cutting each run after a budget and starting a fresh one bounds that tail. Luby, Sinclair
and Zuckerman's universal sequence (1, 1, 2, 1, 1, 2, 4, 1, 1, 2, ...) times a ``unit`` of iterations needs no
knowledge of the run-time distribution: its expected time is within a logarithmic factor of the best fixed cut's
for any distribution ("Optimal speedup of Las Vegas algorithms", 1993).

``solve_with_restarts`` builds each attempt as ``make_planner`` does, on a seed drawn from the run's seed and the
attempt (``np.random.SeedSequence([seed, attempt])``), so the same seed gives the same attempts and the same
result. Budgets (iterations, seconds) hold over all attempts together, and the result counts everything spent.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

import numpy as np

from planners.base.fileio import check_int
from planners.base.planner import Planner, PlanResult, compile_seconds
from planners.base.problem import Problem
from planners.base.registry import make_planner, planner_class


def luby(i: int) -> int:
    """Term ``i`` (from 1) of Luby, Sinclair and Zuckerman's universal sequence: 1, 1, 2, 1, 1, 2, 4, 1, ..."""
    check_int(i, "i", low=1)
    i = int(i)
    while True:
        k = max(1, (i + 1).bit_length() - 1)  # the largest k with 2^k - 1 <= i
        if i == (1 << k) - 1:
            return 1 << (k - 1)
        i -= (1 << k) - 1  # past a whole block of 2^k - 1 terms, the sequence repeats itself


def attempt_seed(seed: int, attempt: int) -> int:
    """The planner seed of attempt ``attempt`` (from 1) of a run seeded ``seed``."""
    return int(np.random.SeedSequence([int(seed), int(attempt)]).generate_state(1)[0])


def solve_with_restarts(name: str, problem: Problem, *, seed: int, unit: int, max_iterations: int | None = None,
                        time_limit: float | None = None, on_attempt: Callable[[Planner], None] | None = None,
                        **kwargs) -> PlanResult:
    """Solve ``problem`` with planner ``name``, restarting after Luby's sequence times ``unit`` iterations.

    Attempt ``a`` (from 1) is ``make_planner(name, problem, seed=attempt_seed(seed, a), **kwargs)`` (a sampler
    given in ``kwargs`` is bound again for it), solved for at most ``luby(a) * unit`` iterations and whatever
    is left of the budgets, until one solves or a budget is spent. For planners that stop at their first
    solution (not RRT* or other anytime planners, whose every attempt would run to its cut).

    Args:
        name: A registered planner name (``make_planner``).
        problem: The planning problem.
        seed: The run's seed; each attempt's comes from it.
        unit: Iterations of the sequence's unit term (1, 1, 2, 1, ... times ``unit``).
        max_iterations: Iterations over all attempts together.
        time_limit: Seconds over all attempts together, building each (a sampler's bind) included and
            compilation left out (as ``Planner.solve`` leaves it out).
        on_attempt: Called with each attempt's planner once it has run (to read its sampler's own counts).
        **kwargs: ``make_planner``'s other arguments (``sampler``, ``step_size``, ...).

    Returns:
        The last attempt's result (its path and tree), with ``iterations``, ``first_solution_iteration``,
        ``collision_checks`` and ``candidates`` counting every attempt, ``time`` the whole call's (compilation
        included, as ``PlanResult.time``), ``seed`` the run's, and ``restarts`` the attempts made before it.
    """
    check_int(seed, "seed", low=0)
    check_int(unit, "unit", low=1)
    if planner_class(name).anytime:
        raise ValueError(f"{planner_class(name).name} is an anytime planner: every attempt would run to its cut")
    if max_iterations is None and time_limit is None:
        raise ValueError("give max_iterations or time_limit (or both)")
    if max_iterations is not None:
        check_int(max_iterations, "max_iterations", low=0)
    if time_limit is not None and not (np.isfinite(time_limit) and time_limit > 0):
        raise ValueError(f"time_limit must be a positive number of seconds, got {time_limit}")
    iterations = checks = candidates = 0
    t0, c0 = time.perf_counter(), compile_seconds()

    def work() -> float:  # seconds so far, building the attempts (a sampler's bind) included, compilation not
        return time.perf_counter() - t0 - (compile_seconds() - c0)

    attempt = 0
    while True:
        attempt += 1
        planner = make_planner(name, problem, seed=attempt_seed(seed, attempt), **kwargs)
        cut = luby(attempt) * unit
        if max_iterations is not None:
            cut = min(cut, max_iterations - iterations)
        left = None if time_limit is None else time_limit - work()
        r = planner.solve(max_iterations=cut, time_limit=left) if left is None or left > 0 else planner.result()
        if on_attempt is not None:
            on_attempt(planner)
        first = None if r.first_solution_iteration is None else iterations + r.first_solution_iteration
        iterations += r.iterations
        checks += r.collision_checks
        candidates += r.candidates
        out_of_time = time_limit is not None and (work() >= time_limit or r.stop_reason == "time_limit")
        if r.solved or out_of_time or (max_iterations is not None and iterations >= max_iterations):
            reason = r.stop_reason if r.solved else "time_limit" if out_of_time else "max_iterations"
            return dataclasses.replace(r, iterations=iterations, first_solution_iteration=first,
                                       collision_checks=checks, candidates=candidates, time=time.perf_counter() - t0,
                                       stop_reason=reason, seed=int(seed), restarts=attempt - 1)
