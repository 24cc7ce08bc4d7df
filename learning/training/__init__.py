"""Training the learned samplers.

``policy``: the guided sampler policy (DAgger imitation of the privileged expert, then PPO);
``imitation``: DAgger and behaviour cloning; ``route``: the route encoder (the grid search's cost-to-go
as targets); ``sweep``: searches over the recipe and the baselines' parameters on Ray Tune.
"""
