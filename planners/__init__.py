"""SamplerGym planning core: worlds, problems, samplers and sampling-based planners (numpy + numba)."""

from planners.grid import OccupancyGrid
from planners.nn import NearestNeighbors
from planners.obprm import OBPRM, ObstacleBasedSampler
from planners.planner import Planner, PlannerData, PlanResult, StepResult, TreeView
from planners.prm import PRM, LazyPRM
from planners.problem import Problem, load_movingai_scenarios
from planners.rigid3d import Box3D, RigidBodyWorld, box_body, load_scene, random_scene, save_scene, thin_wall_scene
from planners.rrt import RRT, RRTConnect
from planners.rrtstar import InformedRRTStar, RRTStar
from planners.samplers import (
    ANCHOR_GOAL,
    ANCHOR_NONE,
    ANCHOR_WORLD,
    GoalBiasedSampler,
    InformedSampler,
    SampleBatch,
    Sampler,
    SamplerBase,
    UniformSampler,
)
from planners.shapes import Circle, GeometricWorld, Rectangle
from planners.smoothing import shortcut, simplify, smooth
from planners.world import World

__all__ = [
    "ANCHOR_GOAL",
    "ANCHOR_NONE",
    "ANCHOR_WORLD",
    "Circle",
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
    "shortcut",
    "simplify",
    "smooth",
]
