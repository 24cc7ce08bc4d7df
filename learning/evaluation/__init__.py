"""The comparison: iterations-to-solution of the learned sampler against uniform and goal bias.

Every run is one planner on one query with one sampler and one seed. Goal bias is swept; the bias
reported as "best" for a family is chosen on a separate tuning split (other map seeds, or other
MovingAI scenarios of the same maps), never on the evaluated queries, from a grid that includes
uniform sampling (bias 0), so the "best" bias is never worse than uniform on the tuning split. The
policy's batch (samples per decision) is chosen on the generated families' tuning maps too
(:func:`best_policy_batch`), and the constant-distribution ablation decides as often. Shifted
map sets (each family's ``generate(..., shifted=True)`` maps) are test-only: they keep the settings
tuned on their family's tuning split. The
privileged expert is a reference, not a competitor: it reads the map's geodesic distance field.

Results are written as a CSV of runs, a Markdown summary, plots, and OMPL benchmark logs
(:func:`write_ompl_logs`) that OMPL's ``ompl_benchmark_statistics.py`` and Planner Arena open.
"""

from __future__ import annotations

from learning.evaluation.outputs import PALETTE, ecdf_figure, medians_figure, save_plots, write_ompl_logs
from learning.evaluation.protocol import (
    Query,
    generated_queries,
    movingai_queries,
    scenarios,
    shifted_name,
    shifted_queries,
    tuned_for_shifted,
)
from learning.evaluation.roster import (
    BUILTIN_SAMPLERS,
    CONSTANT,
    CORRIDOR_FOLLOWER,
    CORRIDOR_UNIFORM,
    FOLLOWER,
    GEODESIC_FRONTIER,
    ROUTE,
    ROUTE_ABLATION,
    bias_sampler,
    constant_sampler,
    parse_user_sampler,
    policy_sampler,
    sampler_bias,
    sampler_constant,
    sampler_policy_batch,
)
from learning.evaluation.runner import run_all, run_on_backend_args, run_one, shared_context, worker_init
from learning.evaluation.tables import (
    MOVINGAI_POOL,
    TARGETS,
    bootstrap_mean_ci,
    carry_targets,
    glance_table,
    headline,
    room_table,
    summarize,
    target_check,
)
from learning.evaluation.tuning import (
    BATCH_TIE,
    GOAL_BIASES,
    POLICY_BATCHES,
    POLICY_TUNING_SEEDS,
    TUNING_BIASES,
    best_bias,
    best_constant,
    best_policy_batch,
    constant_test_tasks,
    constant_tuning_tasks,
    policy_tuning_tasks,
    pooled,
    tuning_tasks,
)
from learning.samplers.registry import user_sampler


__all__ = [
    "BATCH_TIE", "BUILTIN_SAMPLERS", "CONSTANT", "CORRIDOR_FOLLOWER", "CORRIDOR_UNIFORM", "FOLLOWER",
    "GEODESIC_FRONTIER", "GOAL_BIASES", "MOVINGAI_POOL", "PALETTE", "POLICY_BATCHES", "POLICY_TUNING_SEEDS", "Query",
    "ROUTE", "ROUTE_ABLATION", "TARGETS", "TUNING_BIASES", "best_bias", "best_constant", "best_policy_batch",
    "bias_sampler", "bootstrap_mean_ci", "carry_targets", "constant_sampler", "constant_test_tasks",
    "constant_tuning_tasks", "ecdf_figure", "generated_queries", "glance_table", "headline", "medians_figure",
    "movingai_queries", "parse_user_sampler", "policy_sampler", "policy_tuning_tasks", "pooled", "room_table",
    "run_all", "run_on_backend_args", "run_one", "sampler_bias", "sampler_constant", "sampler_policy_batch",
    "save_plots", "scenarios", "shared_context", "shifted_name", "shifted_queries", "summarize", "target_check",
    "tuned_for_shifted", "tuning_tasks", "user_sampler", "worker_init", "write_ompl_logs"
]
