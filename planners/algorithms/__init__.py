"""The planners (RRT, RRT-Connect, RRT*, Informed RRT*, PRM, Lazy-PRM, OB-PRM) and path smoothing.

A planner class drives a compiled kernel from ``planners.kernels``; ``planners.base.registry`` names them.
"""
