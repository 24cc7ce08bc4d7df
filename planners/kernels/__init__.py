"""Compiled (numba) inner loops: collision checks, tree and roadmap growth, state-space maths.

Internal: the Python classes in ``planners.algorithms`` and ``planners.worlds`` are the public way in.
``planners.kernels.state`` owns the layout of every struct the kernels share.
"""
