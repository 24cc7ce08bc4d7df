"""Public home of the nearest-neighbour index (implementation in ``planners._nn``)."""

from planners._nn import NearestNeighbors

__all__ = ["NearestNeighbors"]
