"""Training the learned samplers.

``policy``: the guided sampler policy's training loop (DAgger imitation of the privileged expert, then
PPO), with its pieces beside it: ``config`` (``TrainConfig`` and its JSON reader), ``maps`` (map sets,
DAgger's maps, the training environment), ``validation`` (the score that picks the final policy),
``checkpoints`` (checkpoint files and the run state a resume reads) and ``logs`` (TensorBoard and
``progress.csv``); ``imitation``: DAgger and behaviour cloning; ``route``: the route encoder (the grid
search's cost-to-go as targets); ``sweep``: searches over the recipe and the baselines' parameters on Ray Tune.
"""
