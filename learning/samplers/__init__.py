"""Run-time samplers: the learned policy, any SB3 model, the route sampler and the policy's ablation."""
