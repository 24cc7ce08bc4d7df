"""Old import path of ``learning.samplers.ablation``, kept while ``learning/training.py``, ``route_training.py``,
``sweep.py`` and the training scripts import it; it goes when they move into the new layout.
"""

from learning.samplers.ablation import FRONTIER_GRID, ConstantGuidedSampler  # noqa: F401
