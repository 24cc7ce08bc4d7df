"""Guided sampling shared by the environments and the learned samplers (numpy + numba only).

What an agent sees and how its action becomes a sample, for the ``egocentric`` observation and the
``guided`` action space:

* ``egocentric``: multi-scale windows of map and tree around the tree's progress vertex, turned
  towards the goal (``EgocentricView``; compiled: ``build_pyramid``, ``add_vertices``, ``observe_windows``).
* ``frontier``: free cells next to the tree that it does not cover yet (``Frontier``; compiled:
  ``update_frontier``, ``frontier_cdf``, ``cdf_search``).
* ``guided``: the action classes (a log-polar cell ahead of the progress vertex, or the frontier)
  and ``GuidedSampling``, the per-query object that owns a view and a frontier and turns classes
  into samples. The environment makes one per episode and hands it to its observation
  (``reset(..., guide)``) and its action sampler (``set_guide``); ``learning``'s compiled policy
  sampler calls the compiled functions directly.
"""

from planners.guidance.egocentric import EGO_VECTOR, EgocentricView, add_vertices, build_pyramid, observe_windows
from planners.guidance.frontier import (
    Frontier,
    cdf_search,
    frontier_arrays,
    frontier_cdf,
    frontier_shape,
    update_frontier,
)
from planners.guidance.guided import (
    FRONTIER,
    FRONTIER_TAU,
    N_ACTIONS,
    SCALES,
    WINDOW,
    GuidedSampling,
    ego_class,
    fill_from_cdf,
    scale_cells,
)

__all__ = [
    "EGO_VECTOR",
    "FRONTIER",
    "FRONTIER_TAU",
    "N_ACTIONS",
    "SCALES",
    "WINDOW",
    "EgocentricView",
    "Frontier",
    "GuidedSampling",
    "add_vertices",
    "build_pyramid",
    "cdf_search",
    "ego_class",
    "fill_from_cdf",
    "frontier_arrays",
    "frontier_cdf",
    "frontier_shape",
    "observe_windows",
    "scale_cells",
    "update_frontier",
]
