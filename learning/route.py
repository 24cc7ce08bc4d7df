"""Old import path of ``learning.samplers.route``, kept while ``learning/training.py``, ``route_training.py``,
``sweep.py`` and the training scripts import it; it goes when they move into the new layout.
"""

from learning.samplers.route import RouteNet, route_input, save_route_net, symmetry  # noqa: F401
