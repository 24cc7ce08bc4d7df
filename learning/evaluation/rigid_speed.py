"""What the 6-DoF route samplers cost per query, piece by piece: behind ``scripts/benchmark_rigid_route.py``.

``rigid_route`` does its work once per query, when a planner binds it: the workspace route (the free voxels and the
A* search, ``voxel_route``), its centring (``centre_route``), the orientation model's observation at every route
point (``route_observation``) and the model's pass (``class_probabilities``). ``setup_times`` times each piece and
the whole bind of ``rigid_route`` and of its ablation, per scene, after one untimed bind of each scene (so the
figures leave compilation out), and then what its draws cost per call: 64 samples in windows that follow the trees
(``follow`` 2, the compiled draw a box world's trees take) and 64 and 1,024 along the whole route (``follow`` 0, the
numpy draw of a mesh world's trees and of every roadmap), each the median of ``DRAW_CALLS`` calls after an untimed one.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

#: The pieces ``setup_times`` reports, in the order a bind runs them, then the two binds, then the draws.
PIECES = ("route", "centre", "observation", "model", "bind", "ablation bind", "draw 64 following",
          "draw 64 whole route", "draw 1,024 whole route")
#: Timed calls of each draw (the median is kept): a draw costs tens of microseconds.
DRAW_CALLS = 100


def _ms(repeats: int, fn, *args, **kwargs) -> tuple[float, object]:
    """The median wall time of ``repeats`` calls of ``fn(*args, **kwargs)``, in ms, and its last result."""
    times, out = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn(*args, **kwargs)
        times.append(time.perf_counter() - t)
    return 1e3 * float(np.median(times)), out


def setup_times(problems: Sequence, repeats: int = 3) -> list[dict]:
    """Per problem: ``{"scene", "boxes", "route points", piece: ms for each of PIECES}`` (see the module doc)."""
    import torch

    from learning.models.rigid_orientation import class_probabilities
    from learning.samplers.registry import make_sampler
    from learning.samplers.rigid_route import class_frame
    from planners.guidance.rigid_orientation import route_observation
    from planners.guidance.workspace_route import centre_route, voxel_route

    learned, ablation = make_sampler("rigid_route"), make_sampler("rigid_route_ablation")
    following, whole = make_sampler("rigid_route", follow=2.0), make_sampler("rigid_route", follow=0.0)
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # as the sampler's pass runs (learning.models.threads.planning_threads)
    rows = []
    try:
        for problem in problems:
            world = problem.world
            learned.bind(problem), ablation.bind(problem)  # compiles what the first bind compiles
            row = {"scene": getattr(problem, "name", ""), "boxes": len(getattr(world, "boxes", ()))}
            # the route (and its centring) at the world's own route voxels, as the sampler's bind has them
            row["route"], route = _ms(repeats, voxel_route, world, problem.start, problem.goal)
            if route is None:
                continue
            row["centre"], centred = _ms(repeats, centre_route, world, route, learned.centre)
            seen = class_frame(world)[1]  # as the sampler's bind sees it (a mesh world: from the query's ends)
            ends = np.stack([problem.start[:3], problem.goal[:3]])
            row["observation"], (patches, dirs) = _ms(repeats, route_observation, world, centred, seen,
                                                      learned.net.half, seeds=ends)
            row["model"], _ = _ms(repeats, class_probabilities, learned.net, patches, dirs)
            row["bind"], _ = _ms(repeats, learned.bind, problem)
            row["ablation bind"], _ = _ms(repeats, ablation.bind, problem)
            rng = np.random.default_rng(0)
            for name, sampler, n in (("draw 64 following", following, 64), ("draw 64 whole route", whole, 64),
                                     ("draw 1,024 whole route", whole, 1024)):
                bound = sampler.bind(problem)
                bound.draw(rng, n, None)  # compiles what the first draw compiles
                row[name], _ = _ms(DRAW_CALLS, bound.draw, rng, n, None)
            row["route points"] = len(centred)
            rows.append(row)
    finally:
        torch.set_num_threads(threads)
    return rows
