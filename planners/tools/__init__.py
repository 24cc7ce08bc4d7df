"""Around the planners: benchmarks, OMPL benchmark logs, the OMPL bridge, and the plan-on-a-picture workflow."""
