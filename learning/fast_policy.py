"""Old import path of ``learning.models.fast_policy``, kept while ``learning/training.py``, ``route_training.py``,
``sweep.py`` and the training scripts import it; it goes when they move into the new layout.
"""

from learning.models.fast_policy import KERNELS, FastActor  # noqa: F401
