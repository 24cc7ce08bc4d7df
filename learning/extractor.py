"""The import path Stable-Baselines3 checkpoints name the extractor by (``learning.extractor.EgocentricExtractor``).

SB3 records a policy's ``features_extractor_class`` by its module path inside the zip, and its own
loader imports that path; the shipped ``guided.zip`` and every policy trained before the extractor
moved to ``learning.models.extractor`` name this one. The class lives there.
"""

from learning.models.extractor import EgocentricExtractor, policy_kwargs  # noqa: F401
