"""Evaluation, beside `train/`: rollouts, episode outcomes (`outcomes.py`), stored
evaluation records, feature measurement and `icil-paper eval`."""

from icil_paper.eval.features import lipschitz_diagnostics, measure_features
from icil_paper.eval.outcomes import (
    EvalResult,
    check_policy_fits,
    episode_seed,
    evaluate_many,
    evaluate_policy,
    obs_kind,
    plan_episodes,
    prompt_pool,
)
from icil_paper.eval.rollouts import record_rollout, rollout_policy, run_episodes
from icil_paper.eval.stored import evaluate_run, evaluate_run_many

__all__ = ["EvalResult", "check_policy_fits", "episode_seed",
           "evaluate_many", "evaluate_policy", "evaluate_run", "evaluate_run_many",
           "lipschitz_diagnostics", "measure_features", "obs_kind", "plan_episodes",
           "prompt_pool", "record_rollout", "rollout_policy", "run_episodes"]
