"""The interfaces every planner and world is built on.

``World``, ``Problem``, ``Sampler``, ``Planner`` and its results, the planner registry, and the
library's input error, argument checks and safe file writes.
"""
