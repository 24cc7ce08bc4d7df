"""Old import path of ``learning.samplers.policy``, kept while ``learning/training.py``, ``route_training.py``,
``sweep.py`` and the training scripts import it; it goes when they move into the new layout.
"""

from learning.samplers.policy import OBS_VERSION, PolicySampler  # noqa: F401
