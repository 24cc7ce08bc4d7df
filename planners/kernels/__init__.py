"""Compiled (numba) inner loops: collision checks, tree and roadmap growth, state-space maths.

Internal: the Python classes in ``planners.algorithms`` and ``planners.worlds`` are the public way in.
``planners.kernels.state`` owns the layout of every struct the kernels share. Importing this package
points numba's cache at a folder keyed by the sources (``planners.kernels.cache``): every module
with compiled code imports from here before defining any, and it loads numba's registries
(``planners.kernels.cache.load_registries``).
"""

from planners.kernels import cache as _cache

_cache.configure()
_cache.load_registries()
