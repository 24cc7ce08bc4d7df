"""Worlds a planner plans in: 2-D occupancy grids, geometric 2-D worlds, 6-DoF rigid bodies.

The rigid bodies move among 3-D boxes, or among triangle meshes (``planners.worlds.mesh``, with
OMPL.app's problems in ``planners.worlds.omplapp``; the ``mesh`` extra).
"""
