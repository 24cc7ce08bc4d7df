"""Nearest-neighbour index used by every planner (a compiled forest of static k-d trees)."""
