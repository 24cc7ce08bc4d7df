"""The networks behind the learned samplers, their safe file I/O, and the policy's compiled actor."""
