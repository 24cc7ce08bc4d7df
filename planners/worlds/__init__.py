"""Worlds a planner plans in: 2-D occupancy grids, geometric 2-D worlds, 6-DoF rigid bodies among 3-D boxes."""
