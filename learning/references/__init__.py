"""Privileged references: samplers that read the map's exact geodesic distance (not competitors)."""
