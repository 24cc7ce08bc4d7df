"""What the 6-DoF route samplers cost per query, piece by piece: behind ``scripts/benchmark_rigid_route.py``.

``rigid_route`` does its work once per query, when a planner binds it: the workspace route (the free voxels and the
A* search, ``voxel_route``), its centring (``centre_route``), the orientation model's observation at every route
point (``route_observation``) and the model's pass (``class_probabilities``). ``setup_times`` times each piece and
the whole bind of ``rigid_route`` and of its ablation, per scene, after one untimed bind of each scene (so the
figures leave compilation out).
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

#: The pieces ``setup_times`` reports, in the order a bind runs them, then the two binds.
PIECES = ("route", "centre", "observation", "model", "bind", "ablation bind")


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
            row["route points"] = len(centred)
            rows.append(row)
    finally:
        torch.set_num_threads(threads)
    return rows
