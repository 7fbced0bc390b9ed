"""Episode outcomes: rollouts that turn a trained policy into a success rate.

    from icil_paper.eval import evaluate_many, evaluate_policy
    from icil_paper.runspec import eval_spec
    result = evaluate_policy(policy, eval_spec(preset, "kitchen/open_drawer", episodes=10),
                             prompts=demos)
    result.success_rate, result.ci_low, result.ci_high, result.per_episode

    # one policy on every task of a table, in one call
    results = evaluate_many(policy, [eval_spec(preset, t) for t in tasks],
                            prompts={t: prompt_pool(...) for t in tasks})

Episode i is fixed by the evaluation seed alone: env seed `episode_seed(seed, i)` (above
every demonstration seed), its `prompt_demos` prompts drawn from the pool with
`np.random.default_rng([seed, i])`. Results carry a Wilson 95% interval and the mean motion
smoothness of the episodes.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from icil_paper import sim
from icil_paper.data import ensure_demos, load_demos
from icil_paper.data.sources import EVAL_SEED_BASE
from icil_paper.eval.rollouts import Episode, run_episodes
from icil_paper.metrics import MOTION_MEASURES
from icil_paper.runspec import SCENE_DISTRIBUTIONS, EvalSpec
from icil_paper.sim import scene_distributions
from icil_paper.stats import wilson_interval

__all__ = ["EvalResult", "check_policy_fits", "episode_seed", "evaluate_many",
           "evaluate_policy", "motion_means", "obs_kind", "plan_episodes", "prompt_pool",
           "scene_options"]


@dataclass
class EvalResult:
    """What `evaluate_policy` returns (and what an `eval` record's metrics hold)."""

    task: str
    episodes: int
    successes: int
    success_rate: float
    """successes / episodes."""
    ci_low: float
    """Lower end of the Wilson 95% interval."""
    ci_high: float
    """Upper end of the Wilson 95% interval."""
    mean_steps: float
    """Mean rollout length in env steps."""
    wall_time_s: float
    """Seconds the evaluation took (from `evaluate_many`: the whole call)."""
    per_episode: list[dict[str, Any]] = field(default_factory=list)
    """One dict per episode (`rollouts.run_episodes`)."""
    ldlj: float | None = None
    """Mean log dimensionless jerk of the end-effector paths (higher is smoother)."""
    sparc: float | None = None
    """Mean spectral arc length of the end-effector speed profiles (higher is smoother)."""
    action_jerk: float | None = None
    """Mean squared second difference of the executed actions (lower is smoother)."""

    @property
    def outcomes(self) -> np.ndarray:
        """(episodes,) bool: each episode's success, in episode order."""
        return np.array([bool(e["success"]) for e in self.per_episode])

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> EvalResult:
        names = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in data.items() if k in names})


def episode_seed(seed: int, index: int) -> int:
    """Environment seed of evaluation episode `index` under evaluation seed `seed`."""
    return EVAL_SEED_BASE + 10_000 * int(seed) + int(index)


def obs_kind(policy: Any) -> str:
    """The env observation setting a policy reads: "state", "rgb" or "rgbd"."""
    spec = policy.obs_spec
    if spec.image is None:
        return "state"
    return "rgbd" if spec.depth else "rgb"


def check_policy_fits(policy: Any, task: str) -> None:
    """Raise ValueError when a policy's action or state width differs from the task's."""
    suite = sim.suite_of(task)
    if policy.action_dim != sim.ACTION_DIM:
        raise ValueError(f"the policy acts in {policy.action_dim} dimensions but {task} takes "
                         f"{sim.ACTION_DIM}-dimensional actions")
    width = int(sum(sim.obs_dims(suite)))
    if policy.obs_spec.lowdim_dim and policy.obs_spec.lowdim_dim != width:
        raise ValueError(f"the policy reads {policy.obs_spec.lowdim_dim}-dimensional state "
                         f"(proprio + object) but {task} ({suite} suite) gives {width}: it was "
                         "trained on another suite")


def prompt_pool(ev: EvalSpec, obs: str, demos_per_task: int, data_seed: int,
                preset: Any = None, progress: bool = True) -> list[Any]:
    """The prompt demonstrations an EvalSpec draws from, in the data folder of `preset`."""
    if preset is None:
        raise ValueError("prompt_pool needs the preset (preset=...): prompt data sets "
                         "live under data/<preset>/")
    task = ev.prompt_task or ev.task
    path = ensure_demos(preset, task, ev.prompt_source, n=demos_per_task,
                        seed=data_seed, obs=obs, progress=progress)
    demos = load_demos(path, limit=demos_per_task)
    if ev.prompt_steps is not None:  # at least 1 (EvalSpec checks its fields when built)
        demos = [_first_steps(d, ev.prompt_steps) for d in demos]
    return demos


def _first_steps(demo: Any, n: int) -> Any:
    cut = {"actions": demo.actions[:n], "obs": {k: v[:n] for k, v in demo.obs.items()}}
    for name in ("states", "rewards"):
        if getattr(demo, name, None) is not None:
            cut[name] = getattr(demo, name)[:n]
    return dataclasses.replace(demo, **cut)


# --------------------------------------------------------------------------- evaluation
def scene_options(spec: EvalSpec) -> tuple[tuple[str, Any], ...]:
    """The env options of `spec`'s scene distribution: none for the default."""
    return () if spec.scenes == SCENE_DISTRIBUTIONS[0] else (("scenes", spec.scenes),)


def _check_scenes(spec: EvalSpec) -> None:
    if scene_options(spec) and spec.scenes not in scene_distributions(spec.task):
        offered = scene_distributions(spec.task)
        raise ValueError(f"{spec.task} has no {spec.scenes!r} scene distribution (its suite "
                         + (f"offers {list(offered)})" if offered else "has only its own)")
                         + "; evaluate it with scenes='generated'")


def plan_episodes(spec: EvalSpec, pool_size: int = 0, prompt_demos: int = 1,
                  spec_index: int = 0) -> list[Episode]:
    """The episodes of `spec`, each with `prompt_demos` indices into a pool of `pool_size`."""
    plan = []
    options = scene_options(spec)
    for i in range(spec.episodes):
        chosen: tuple[int, ...] = ()
        if pool_size:
            rng = np.random.default_rng([spec.seed, i])
            chosen = tuple(int(j) for j in rng.choice(pool_size, size=prompt_demos,
                                                       replace=pool_size < prompt_demos))
        plan.append(Episode(spec=spec_index, task=spec.task, index=i,
                            seed=episode_seed(spec.seed, i), prompt=chosen,
                            max_steps=spec.max_steps, env_options=options))
    return plan


def _pools(specs: Sequence[EvalSpec], prompts: Any) -> list[list[Any]]:
    if prompts is None:
        return [[] for _ in specs]
    if isinstance(prompts, Mapping):
        return [list(prompts.get(spec.task) or []) for spec in specs]
    pools = list(prompts)
    if len(pools) != len(specs) or not all(p is None or isinstance(p, (list, tuple))
                                           for p in pools):
        raise ValueError(f"prompts must map each task to its prompt pool, or be a list of "
                         f"{len(specs)} pools (lists of demonstrations), one per spec")
    return [list(p or []) for p in pools]


def evaluate_many(policy: Any, specs: Sequence[EvalSpec],
                  prompts: Mapping[str, Sequence[Any]] | Sequence[Sequence[Any] | None] | None = None,
                  record_dir: str | Path | None = None, progress: bool = True,
                  env_options: Mapping[str, Any] | None = None,
                  env_factory: Callable[..., Any] | None = None, batch_size: int | None = None,
                  keep_envs: bool = False) -> list[EvalResult]:
    """Evaluate one policy on many specs in one call; one EvalResult per spec, in order.

    `prompts` is {task: pool} or one pool per spec (`prompt_pool`); `env_factory`
    (task, obs=, seed=, **env_options) -> env replaces `sim.make_env`.
    """
    specs = list(specs)
    if not specs:
        raise ValueError("evaluate_many needs at least one EvalSpec")
    pools = _pools(specs, prompts)
    k = getattr(policy.config, "prompt_demos", 1)
    episodes: list[Episode] = []
    for i, (spec, pool_i) in enumerate(zip(specs, pools, strict=True)):
        if env_factory is None:
            check_policy_fits(policy, spec.task)
            _check_scenes(spec)
        if policy.uses_prompt and not pool_i:
            raise ValueError(f"{policy.name} needs prompt demonstrations for {spec.task} "
                             "(pass prompts=, e.g. prompt_pool(spec, ...))")
        episodes += plan_episodes(spec, len(pool_i) if policy.uses_prompt else 0, k, i)
    desc = f"eval {specs[0].task}" if len(specs) == 1 else f"eval {len(specs)} tasks"
    start = time.perf_counter()
    rows = run_episodes(policy, episodes, prompts=dict(enumerate(pools)), obs=obs_kind(policy),
                        batch_size=batch_size, env_factory=env_factory,
                        env_options=env_options, record_dir=record_dir, progress=progress,
                        desc=desc, keep_envs=keep_envs)
    wall = round(time.perf_counter() - start, 3)
    results = []
    for i, spec in enumerate(specs):
        per_episode = [r for ep, r in zip(episodes, rows, strict=True) if ep.spec == i]
        successes = int(sum(r["success"] for r in per_episode))
        lo, hi = wilson_interval(successes, len(per_episode))
        results.append(EvalResult(
            task=spec.task, episodes=len(per_episode), successes=successes,
            success_rate=successes / len(per_episode), ci_low=lo, ci_high=hi,
            mean_steps=float(np.mean([r["steps"] for r in per_episode])), wall_time_s=wall,
            per_episode=per_episode, **motion_means(per_episode)))
    return results


def motion_means(per_episode: Sequence[Mapping[str, Any]]) -> dict[str, float | None]:
    """Each of `metrics.MOTION_MEASURES` averaged over the episodes where it is defined."""
    out: dict[str, float | None] = {}
    for name in MOTION_MEASURES:
        values = [e.get(name) for e in per_episode]
        values = [float(v) for v in values if v is not None]
        out[name] = float(f"{np.mean(values):.7g}") if values else None
    return out


def evaluate_policy(policy: Any, spec: EvalSpec, prompts: Sequence[Any] | None = None,
                    record_dir: str | Path | None = None,
                    progress: bool = True, env_options: Mapping[str, Any] | None = None,
                    env_factory: Callable[..., Any] | None = None,
                    batch_size: int | None = None) -> EvalResult:
    """`evaluate_many` for one spec, `prompts` its prompt pool."""
    return evaluate_many(policy, [spec], [list(prompts or [])], record_dir=record_dir,
                         progress=progress, env_options=env_options, env_factory=env_factory,
                         batch_size=batch_size)[0]
