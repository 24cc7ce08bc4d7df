"""The comparison: iterations-to-solution of the learned sampler against uniform and goal bias.

One call runs it: ``compare(Comparison(queries, protocol, ...), out)`` (``learning.evaluation.comparison``),
which ``scripts/evaluate.py`` wraps; notebooks, other planners and other scene sets enter there.

Every run is one planner on one query with one sampler and one seed (a ``Task``: the sampler as a
``SamplerSpec``, a registered name and its parameters), made under one ``Protocol`` (step, tolerance,
iteration cap, seeds, split sizes); ``runs.csv`` records each run's spec as JSON (its ``sampler_spec``
column) beside the sampler's label. Workers receive a ``RunContext`` (the protocol, the models loaded
once, the MovingAI scenarios) with their tasks. Goal bias is swept; the bias
reported as "best" for a family is chosen on a separate tuning split (other map seeds, or other
MovingAI scenarios of the same maps), never on the evaluated queries, from a grid that includes
uniform sampling (bias 0), so the "best" bias is never worse than uniform on the tuning split. The
policy's batch (samples per decision) is chosen on the generated families' tuning maps too
(:func:`best_policy_batch`), and the constant-distribution ablation decides as often. Shifted
map sets (each family's ``generate(..., shifted=True)`` maps) are test-only: they keep the settings
tuned on their family's tuning split. The
privileged expert and ``exact_route`` (the route sampler on the exact cost-to-go, at the route
encoder's own settings) are references, not competitors: they read the map's geodesic distance
field; ``exact_route`` runs on every map set, so each shows how much room the route encoder has over
its ablation.

Results are written as a CSV of runs, a Markdown summary, plots, and OMPL benchmark logs
(:func:`write_ompl_logs`) that OMPL's ``ompl_benchmark_statistics.py`` and Planner Arena open.
"""

from __future__ import annotations

from learning.evaluation.comparison import (
    Comparison,
    ComparisonInterrupted,
    Part,
    PartReport,
    Results,
    compare,
    default_queries,
    is_roadmap,
)
from learning.evaluation.outputs import PALETTE, ecdf_figure, medians_figure, save_plots, write_ompl_logs
from learning.evaluation.protocol import (
    Protocol,
    Query,
    generated_queries,
    movingai_queries,
    scenarios,
    shifted_name,
    shifted_queries,
    tuned_for_shifted,
)
from learning.evaluation.rigid import RigidPart
from learning.evaluation.roster import (
    BUILTIN_SAMPLERS,
    CONSTANT,
    EXACT_ROUTE,
    EXPERT,
    FOLLOWER,
    LAZY_ROUTE,
    OBSTACLE_BASED,
    ROUTE,
    ROUTE_ABLATION,
    Task,
    bias_sampler,
    bias_spec,
    constant_sampler,
    constant_spec,
    evaluation_tasks,
    fixed_specs,
    parse_user_sampler,
    policy_sampler,
    policy_spec,
    sampler_bias,
    sampler_label,
    spec_bias,
)
from learning.evaluation.runner import RunContext, run_all, run_on_backend_args, run_one, shared_context, worker_init
from learning.evaluation.tables import (
    EXACT_FAILS,
    MOVINGAI_POOL,
    TARGETS,
    bootstrap_mean_ci,
    carry_targets,
    glance_table,
    headline,
    median_ratio,
    query_bootstrap,
    room_table,
    success_difference,
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
    spec_of,
    tuning_tasks,
)
from learning.samplers.registry import USER, ModelCache, SamplerSpec, user_sampler

__all__ = [
    "Comparison", "ComparisonInterrupted", "OBSTACLE_BASED", "Part", "PartReport", "Results",
    "compare", "default_queries", "is_roadmap",
    "BATCH_TIE", "BUILTIN_SAMPLERS", "CONSTANT", "EXACT_FAILS", "EXACT_ROUTE", "EXPERT", "FOLLOWER", "GOAL_BIASES",
    "LAZY_ROUTE", "MOVINGAI_POOL", "ModelCache", "PALETTE", "POLICY_BATCHES", "POLICY_TUNING_SEEDS", "Protocol",
    "Query", "ROUTE", "ROUTE_ABLATION", "RigidPart", "RunContext", "SamplerSpec", "TARGETS", "TUNING_BIASES", "Task",
    "USER", "best_bias",
    "best_constant", "best_policy_batch", "bias_sampler", "bias_spec", "bootstrap_mean_ci", "carry_targets",
    "constant_sampler", "constant_spec", "constant_test_tasks", "constant_tuning_tasks", "ecdf_figure",
    "evaluation_tasks", "fixed_specs", "generated_queries", "glance_table", "headline", "median_ratio",
    "medians_figure", "movingai_queries", "parse_user_sampler", "policy_sampler", "policy_spec", "policy_tuning_tasks",
    "pooled", "query_bootstrap", "room_table", "run_all", "run_on_backend_args", "run_one", "sampler_bias",
    "sampler_label", "save_plots", "scenarios", "shared_context", "shifted_name", "shifted_queries", "spec_bias",
    "spec_of", "success_difference", "summarize", "target_check", "tuned_for_shifted", "tuning_tasks", "user_sampler",
    "worker_init", "write_ompl_logs",
]
