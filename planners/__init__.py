"""SamplerGym planning core: worlds, problems, samplers and sampling-based planners (numpy + numba)."""

from planners.algorithms.obprm import OBPRM, ObstacleBasedSampler
from planners.algorithms.prm import PRM, LazyPRM
from planners.algorithms.restarts import luby, solve_with_restarts
from planners.algorithms.rrt import RRT, RRTConnect
from planners.algorithms.rrtstar import InformedRRTStar, RRTStar
from planners.algorithms.smoothing import shortcut, simplify, smooth
from planners.base.planner import Planner, PlannerData, PlanResult, StepResult, TreeView
from planners.base.problem import Problem
from planners.base.registry import make_planner, planner_names, register_planner
from planners.base.samplers import (
    ANCHOR_GOAL,
    ANCHOR_NONE,
    ANCHOR_WORLD,
    DrawInterrupted,
    GoalBiasedSampler,
    InformedSampler,
    SampleBatch,
    Sampler,
    SamplerBase,
    UniformSampler,
    draw_classical_in_loops,
)
from planners.base.world import World
from planners.datastructures.nn import NearestNeighbors
from planners.maps.movingai import load_movingai_scenarios, movingai_dir
from planners.worlds.grid import OccupancyGrid
from planners.worlds.rigid3d import (
    Box3D,
    RigidBodyWorld,
    box_body,
    load_scene,
    random_scene,
    save_scene,
    thin_wall_scene,
)
from planners.worlds.shapes import Circle, GeometricWorld, Rectangle

__all__ = [
    "ANCHOR_GOAL",
    "ANCHOR_NONE",
    "ANCHOR_WORLD",
    "Circle",
    "DrawInterrupted",
    "GeometricWorld",
    "GoalBiasedSampler",
    "InformedRRTStar",
    "InformedSampler",
    "LazyPRM",
    "NearestNeighbors",
    "OBPRM",
    "ObstacleBasedSampler",
    "OccupancyGrid",
    "PlanResult",
    "PRM",
    "Planner",
    "PlannerData",
    "Problem",
    "RRT",
    "RRTConnect",
    "RRTStar",
    "Rectangle",
    "SampleBatch",
    "Sampler",
    "SamplerBase",
    "StepResult",
    "TreeView",
    "UniformSampler",
    "World",
    "Box3D",
    "RigidBodyWorld",
    "box_body",
    "load_scene",
    "random_scene",
    "save_scene",
    "thin_wall_scene",
    "load_movingai_scenarios",
    "draw_classical_in_loops",
    "make_planner",
    "planner_names",
    "register_planner",
    "movingai_dir",
    "shortcut",
    "simplify",
    "smooth",
    "luby",
    "solve_with_restarts",
]
