"""Old import path of ``learning.models.route_net``, kept while ``learning/training.py``, ``route_training.py``,
``sweep.py`` and the training scripts import it; it goes when they move into the new layout.
"""

from learning.models.route_net import RouteNet, route_input, save_route_net, symmetry  # noqa: F401
