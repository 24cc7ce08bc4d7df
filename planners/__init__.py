"""SamplerGym planning core: worlds, problems, samplers and sampling-based planners (numpy + numba)."""

from planners.grid import OccupancyGrid
from planners.nn import NearestNeighbors
from planners.planner import Planner, PlannerData, PlanResult, StepResult, TreeView
from planners.problem import Problem, load_movingai_scenarios
from planners.rrt import RRT, RRTConnect
from planners.samplers import GoalBiasedSampler, InformedSampler, SampleBatch, Sampler, SamplerBase, UniformSampler
from planners.world import World

__all__ = [
    "GoalBiasedSampler",
    "InformedSampler",
    "NearestNeighbors",
    "OccupancyGrid",
    "PlanResult",
    "Planner",
    "PlannerData",
    "Problem",
    "RRT",
    "RRTConnect",
    "SampleBatch",
    "Sampler",
    "SamplerBase",
    "StepResult",
    "TreeView",
    "UniformSampler",
    "World",
    "load_movingai_scenarios",
]
