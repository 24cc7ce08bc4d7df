"""The layout of every struct the compiled kernels share, in one place.

Kernels take NamedTuples of arrays rather than objects (numba compiles and caches them as plain
structs) and small integer/float state arrays indexed by the slot constants below. Python classes
read a slot by name (``istate[I_N]``) and a struct by field (``tree.X``); nothing indexes by position.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Tree(NamedTuple):
    """A tree's (or roadmap's) vertex arrays, grown in place up to their capacity.

    ``X`` states; ``E`` their nearest-neighbour embedding (the same array as ``X`` for real-vector
    spaces); ``parent`` index and ``cost`` to come (roadmaps leave them unused); ``perm``, ``split``,
    ``box``: the k-d forest of ``planners.datastructures.nn`` over ``E``.
    """

    X: np.ndarray
    E: np.ndarray
    parent: np.ndarray
    cost: np.ndarray
    perm: np.ndarray
    split: np.ndarray
    box: np.ndarray


class WorldKernel(NamedTuple):
    """A world as the collision kernels see it (``planners.kernels.geometry``); unused arrays are 1x1 placeholders.

    ``kind`` is one of ``geometry.WORLD_GRID``, ``WORLD_SHAPES``, ``WORLD_RIGID``, ``WORLD_MESH``; ``grid`` the (H, W)
    uint8 obstacle grid; ``geom`` shape or box rows; ``body`` a rigid body's points; ``params`` the
    kind's numbers (see ``planners.kernels.geometry``).
    """

    kind: int
    grid: np.ndarray
    geom: np.ndarray
    body: np.ndarray
    params: np.ndarray


# --- integer state of a planner (``Planner._istate``) ---------------------------------------------
# slots 0-10: every planner
I_N = 0  # vertices in the (start) tree
I_ITER = 1  # iterations (samples consumed)
I_CHECKS = 2  # collision checks (one per motion or state validated)
I_SOLVED = 3  # 1 once a solution exists
I_GOAL_V = 4  # vertex that reached the goal region (RRT) / start-tree side of the join (Connect)
I_BEST_V = 5  # start-tree vertex nearest the goal: the progress anchor
I_ADDED = 6  # vertex added by the last iteration, -1 if none
I_N_B = 7  # vertices in the goal tree (Connect)
I_SWAP = 8  # which tree extends next (Connect)
I_JOIN_B = 9  # goal-tree side of the join (Connect)
I_FIRST = 10  # iteration at which the first solution was found
# slots 11-13: one planner family each
I_N_GOAL = 11  # RRT*: vertices in the goal region
I_E = 11  # PRM: edges stored
I_QS = 12  # PRM: start vertex of the current query
I_QG = 13  # PRM: goal vertex of the current query
N_ISTATE = 16

# --- float state of a planner (``Planner._fstate``) -----------------------------------------------
F_BEST_D = 0  # distance from the anchor vertex to the goal
F_BEST_COST = 1  # cost of the best solution so far
N_FSTATE = 4

# --- roadmap edge and vertex status (Lazy-PRM checks them on demand) ---------------------------------
EDGE_VALID = 1
EDGE_UNKNOWN = 0
EDGE_INVALID = -1
V_VALID = 1
V_UNKNOWN = 0
V_INVALID = -1

# --- OB-PRM sampler state (``ObstacleBasedSampler``) ----------------------------------------------
S_POS = 0  # uniforms consumed from the pool
S_PENDING = 1  # attempts not yet charged to a returned sample
S_CHECKS = 2  # state validity checks performed (accumulates across calls)
S_SEEKING = 3  # 1 while the sample being made was chosen to be obstacle-based
N_STATE = 4
