"""Rollouts that turn a trained policy into a success rate, and `icil-paper eval`.

    from icil_paper.evaluate import evaluate_policy
    from icil_paper.runspec import eval_spec
    result = evaluate_policy(policy, eval_spec(preset, "kitchen/open_drawer", episodes=10),
                             prompts=demos, workers=2)
    result.success_rate, result.ci_low, result.ci_high, result.per_episode

Each episode i (of `EvalSpec.episodes`) is fixed by the evaluation seed alone:

- its environment seed is `EVAL_SEED_BASE + 10_000 * seed + i` (`icil_paper.data`), above
  every seed demonstrations are generated with, so rollouts start from unseen scenes;
- for an in-context policy, its prompt is `ICRTConfig.prompt_demos` demonstrations drawn
  from the prompt pool with `np.random.default_rng([seed, i])`; the pool is the first
  demonstrations of the task's data set from `EvalSpec.prompt_source` (or of another task's,
  `prompt_task`, for the prompt ablation), each cut to `prompt_steps` if that is set;
- it runs until the task reports success, the episode ends, or `max_steps` (default the
  task's horizon). Actions are clipped to [-1, 1].

So the same seed gives the same episodes whether they run in one process or many. With
`workers > 1` the episodes are split over spawned processes; each builds its own
environment and its own copy of the policy from the policy's spec and state dict. The
success rate comes with a Wilson 95% interval (`icil_paper.stats`).

Before any rollout the policy's observation and action widths are checked against the
task's (`check_policy_fits`), so a policy trained on another suite fails with both widths
named. With a `record_dir` each rollout is written as a rerun recording (the scene state,
camera frames for image observations, the executed actions and, when the policy has an
action tokenizer, its latent tokens of those actions) with a static picture beside it.
"""

from __future__ import annotations

import argparse
import dataclasses
import io
import json
import sys
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch

from icil_paper.runspec import EvalSpec
from icil_paper.stats import wilson_interval


@dataclass
class EvalResult:
    """What `evaluate_policy` returns (and what an `eval` record's metrics hold)."""

    task: str
    """The task rolled out."""
    episodes: int
    """Rollouts run."""
    successes: int
    """Rollouts that reached the task's success predicate."""
    success_rate: float
    """successes / episodes."""
    ci_low: float
    """Lower end of the Wilson 95% interval."""
    ci_high: float
    """Upper end of the Wilson 95% interval."""
    mean_steps: float
    """Mean rollout length in env steps."""
    wall_time_s: float
    """Seconds the evaluation took."""
    per_episode: list[dict[str, Any]] = field(default_factory=list)
    """One dict per episode: episode, seed, success, steps, return, prompt (indices into the
    prompt pool), wall_time_s and, when recorded, recording."""

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
    """Environment seed of evaluation episode `index` under evaluation seed `seed`.

    Evaluation seeds start at `icil_paper.data.EVAL_SEED_BASE`, above every seed that
    demonstration generation can use.
    """
    from icil_paper.data.sources import EVAL_SEED_BASE

    return EVAL_SEED_BASE + 10_000 * int(seed) + int(index)


def obs_kind(policy: Any) -> str:
    """The env observation setting a policy reads: "state", "rgb" or "rgbd"."""
    spec = policy.obs_spec
    if spec.image is None:
        return "state"
    return "rgbd" if spec.depth else "rgb"


def _policy_blob(policy: Any) -> bytes:
    buf = io.BytesIO()
    torch.save({"spec": json.dumps(policy.spec), "state_dict": policy.state_dict()}, buf)
    return buf.getvalue()


def _policy_from_blob(blob: bytes) -> Any:
    from icil_paper.policies.base import build_policy

    state = torch.load(io.BytesIO(blob), map_location="cpu", weights_only=True)
    policy = build_policy(json.loads(state["spec"]))
    policy.load_state_dict(state["state_dict"])
    return policy.eval()


def check_policy_fits(policy: Any, task: str) -> None:
    """Raise ValueError when a policy's action or low-dimensional observation width differs
    from the task's (both widths named), before any rollout."""
    from icil_paper import sim

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
                preset: str | None = None, progress: bool = True) -> list[Any]:
    """The prompt demonstrations an EvalSpec draws from (see the module docstring)."""
    from icil_paper.config import active_preset_name
    from icil_paper.data import ensure_demos, load_demos

    task = ev.prompt_task or ev.task
    path = ensure_demos(active_preset_name(preset), task, ev.prompt_source, n=demos_per_task,
                        seed=data_seed, obs=obs, progress=progress)
    demos = load_demos(path, limit=demos_per_task)
    if ev.prompt_steps is not None:
        if ev.prompt_steps < 1:
            raise ValueError(f"prompt_steps must be at least 1, got {ev.prompt_steps}")
        demos = [_first_steps(d, ev.prompt_steps) for d in demos]
    return demos


def _first_steps(demo: Any, n: int) -> Any:
    """A demonstration cut to its first `n` steps (per-step arrays cut alike)."""
    cut = {"actions": demo.actions[:n], "obs": {k: v[:n] for k, v in demo.obs.items()}}
    for name in ("states", "rewards"):
        if getattr(demo, name, None) is not None:
            cut[name] = getattr(demo, name)[:n]
    return dataclasses.replace(demo, **cut)


# --------------------------------------------------------------------------- one worker
def _run_episodes(policy: Any, task: str, kind: str, plan: list[dict[str, Any]],
                  prompts: Mapping[int, Any], max_steps: int | None, record_dir: str | None,
                  env_options: Mapping[str, Any], env_factory: Callable[..., Any] | None = None,
                  progress: bool = False) -> list[dict[str, Any]]:
    """Roll out the planned episodes in this process with one environment."""
    from tqdm.auto import tqdm

    if env_factory is None:
        from icil_paper.sim import make_env as env_factory

    policy.eval()
    env = env_factory(task, obs=kind, seed=plan[0]["seed"], **dict(env_options))
    results = []
    try:
        for ep in tqdm(plan, desc=f"eval {task}", disable=not progress, leave=False):
            results.append(_run_episode(policy, env, ep, [prompts[i] for i in ep["prompt"]],
                                        max_steps, record_dir))
    finally:
        env.close()
    return results


def rollout(policy: Any, env: Any, seed: int, prompt: Sequence[Any] | None = None,
            max_steps: int | None = None, keep_trace: bool = False) -> dict[str, Any]:
    """Run one episode: reset the env with `seed`, reset the policy with `prompt`, act until
    success, the episode's end or `max_steps` (default: the env's horizon).

    Returns {"success", "steps", "return"} and, with `keep_trace`, "obs" (list of the
    observations acted on), "actions" (T, A) executed (clipped to [-1, 1]) and "final_obs".
    """
    obs, info = env.reset(seed=seed)
    policy.reset(prompt=list(prompt) if policy.uses_prompt and prompt is not None else None,
                 instruction=getattr(env, "instruction", ""))
    limit = int(max_steps or env.horizon)
    success, total_reward, steps = False, 0.0, 0
    seen, actions = [], []
    for steps in range(1, limit + 1):  # noqa: B007 (steps is read after the loop)
        action = np.clip(policy.select_action(obs), -1.0, 1.0).astype(np.float32)
        if keep_trace:
            seen.append(obs)
            actions.append(action)
        obs, reward, terminated, truncated, info = env.step(action)
        total_reward += float(reward)
        if info.get("success"):
            success = True
            break
        if terminated or truncated:
            break
    out: dict[str, Any] = {"success": bool(success), "steps": steps,
                           "return": round(total_reward, 6)}
    if keep_trace:
        out.update(obs=seen, actions=np.asarray(actions, np.float32).reshape(-1, env.action_dim),
                   final_obs=obs)
    return out


def _run_episode(policy: Any, env: Any, ep: Mapping[str, Any], prompt: list[Any],
                 max_steps: int | None, record_dir: str | None) -> dict[str, Any]:
    start = time.perf_counter()
    out = rollout(policy, env, ep["seed"], prompt, max_steps, keep_trace=record_dir is not None)
    result = {"episode": ep["index"], "seed": ep["seed"], "success": out["success"],
              "steps": out["steps"], "return": out["return"], "prompt": list(ep["prompt"]),
              "wall_time_s": round(time.perf_counter() - start, 3)}
    if record_dir is not None:
        result["recording"] = record_rollout(policy, str(getattr(env, "name", "task")), ep, out,
                                             record_dir)
    return result


def record_rollout(policy: Any, task: str, ep: Mapping[str, Any], trace: Mapping[str, Any],
                   record_dir: str | Path) -> str | None:
    """Write one rollout as a rerun recording with its static picture.

    Args:
        policy: the policy that acted; its tokenizer (if any) gives the latent action tokens.
        task: the task name (for the file name, the title and the object's position).
        ep: the episode's {"index", "seed"}.
        trace: `rollout(..., keep_trace=True)`'s output ("obs", "actions", "success").
        record_dir: the folder of `<task>__seed<seed>.rrd` and `.png`.

    Returns the `.rrd` path, the `.png` path where rerun is unavailable, or None where
    recording is unavailable altogether.
    """
    try:
        from icil_paper.recording import record_episode
    except ImportError:
        warnings.warn("icil_paper.recording is not available; rollouts are not recorded",
                      stacklevel=2)
        return None
    actions = np.asarray(trace["actions"], np.float32)
    latents = None
    tokenizer = getattr(policy, "tokenizer", None)
    if tokenizer is not None and len(actions):
        with torch.no_grad():  # the latent action tokens of the executed actions
            latents = tokenizer(torch.from_numpy(actions)[None]).embeddings[0].cpu().numpy()
    path = Path(record_dir) / f"{task.replace('/', '-')}__seed{ep['seed']}.rrd"
    title = (f"{getattr(policy, 'name', 'policy')} on {task}, episode {ep['index']} "
             f"(env seed {ep['seed']}): {'success' if trace['success'] else 'failure'}")
    from icil_paper.sim import object_position

    out = record_episode(path, trace["obs"], actions, latents=latents, title=title,
                         object_position=object_position(task))
    return str(out["rrd"] or out["png"])


def _worker(blob: bytes, task: str, kind: str, plan: list[dict[str, Any]],
            prompts: Mapping[int, Any], max_steps: int | None, record_dir: str | None,
            env_options: Mapping[str, Any], env_factory: Callable[..., Any] | None
            ) -> list[dict[str, Any]]:
    torch.set_num_threads(1)
    return _run_episodes(_policy_from_blob(blob), task, kind, plan, prompts, max_steps,
                         record_dir, env_options, env_factory)


# --------------------------------------------------------------------------- evaluation
def evaluate_policy(policy: Any, spec: EvalSpec, prompts: Sequence[Any] | None = None,
                    workers: int = 1, record_dir: str | Path | None = None,
                    progress: bool = True, env_options: Mapping[str, Any] | None = None,
                    env_factory: Callable[..., Any] | None = None) -> EvalResult:
    """Success rate of `policy` over the rollouts `spec` describes (see the module docstring).

    Args:
        policy: a trained policy (`icil_paper.policies`).
        spec: the task, episodes, seed, step limit and prompt choice (`runspec.EvalSpec`).
        prompts: the prompt pool of an in-context policy (`prompt_pool` gives the spec's).
        workers: processes that run rollouts (1: in this process).
        record_dir: write a rerun recording of each rollout there.
        env_options: extra keyword options for `make_env`.
        env_factory: a picklable callable (task, obs=, seed=, **env_options) -> env used
            instead of `icil_paper.sim.make_env` (e.g. a test suite's).
    """
    if spec.episodes < 1:
        raise ValueError(f"episodes must be at least 1, got {spec.episodes}")
    if spec.max_steps is not None and spec.max_steps < 1:
        raise ValueError(f"max_steps must be at least 1 (or None), got {spec.max_steps}")
    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    if env_factory is None:
        check_policy_fits(policy, spec.task)
    pool: list[Any] = []
    if policy.uses_prompt:
        pool = list(prompts or [])
        if not pool:
            raise ValueError(f"{policy.name} needs prompt demonstrations for {spec.task} "
                             "(pass prompts=, e.g. prompt_pool(spec, ...))")
    k = getattr(policy.config, "prompt_demos", 1)
    plan = []
    for i in range(spec.episodes):
        chosen: list[int] = []
        if pool:
            rng = np.random.default_rng([spec.seed, i])
            chosen = [int(j) for j in rng.choice(len(pool), size=k, replace=len(pool) < k)]
        plan.append({"index": i, "seed": episode_seed(spec.seed, i), "prompt": chosen})
    used = {j: pool[j] for ep in plan for j in ep["prompt"]}
    if record_dir is not None:
        Path(record_dir).mkdir(parents=True, exist_ok=True)
        record_dir = str(record_dir)
    kind, env_options = obs_kind(policy), dict(env_options or {})

    start = time.perf_counter()
    was_training = policy.training
    policy.eval()
    task, max_steps = spec.task, spec.max_steps
    if workers <= 1 or spec.episodes <= 1:
        from icil_paper.train.optim import cpu_threads

        with cpu_threads(1):  # one episode at a time gains nothing from a thread pool
            per_episode = _run_episodes(policy, task, kind, plan, used, max_steps, record_dir,
                                        env_options, env_factory, progress=progress)
    else:
        import multiprocessing as mp

        from tqdm.auto import tqdm

        blob = _policy_blob(policy)
        n = min(workers, spec.episodes)
        shards = [plan[w::n] for w in range(n)]
        ctx = mp.get_context("spawn")
        with ProcessPoolExecutor(max_workers=n, mp_context=ctx) as ex:
            futures = [ex.submit(_worker, blob, task, kind, shard,
                                 {j: used[j] for ep in shard for j in ep["prompt"]},
                                 max_steps, record_dir, env_options, env_factory)
                       for shard in shards]
            per_episode = []
            for f in tqdm(futures, desc=f"eval {task} ({n} workers)", disable=not progress,
                          leave=False):
                per_episode.extend(f.result())
        per_episode.sort(key=lambda r: r["episode"])
    policy.train(was_training)

    successes = int(sum(r["success"] for r in per_episode))
    lo, hi = wilson_interval(successes, len(per_episode))
    return EvalResult(task=task, episodes=len(per_episode), successes=successes,
                      success_rate=successes / len(per_episode), ci_low=lo, ci_high=hi,
                      mean_steps=float(np.mean([r["steps"] for r in per_episode])),
                      wall_time_s=round(time.perf_counter() - start, 3), per_episode=per_episode)


def eval_record_name(run: Any, ev: EvalSpec) -> str:
    """The results-store name of an evaluation: `<label>__<task>__<prompt source>[...]`."""
    name = f"{run.label}__{ev.task}__{ev.prompt_source}"
    if ev.prompt_task:
        name += f"__prompt-{ev.prompt_task.replace('/', '-')}"
    if ev.prompt_steps:
        name += f"__first{ev.prompt_steps}"
    return f"{name}__seed{run.seed}"


def evaluate_run(run: Any, ev: EvalSpec, policy: Any | Callable[[], Any], store: Any,
                 preset: str | None = None, workers: int = 1, record_dir: str | Path | None = None,
                 force: bool = False, progress: bool = True) -> dict[str, Any]:
    """The stored evaluation of `run`'s trained policy as `ev` describes, computed if missing.

    `policy` is the trained policy or a function that loads it (called only when the
    record must be computed). The record's config is the keyed content of both specs, so
    its key is `runspec.eval_key(run, ev)`. Returns the record.
    """
    from icil_paper.specs import to_dict

    config = {"run": to_dict(run, keyed_only=True), "eval": to_dict(ev, keyed_only=True)}

    def compute() -> dict[str, Any]:
        trained = policy if isinstance(policy, torch.nn.Module) else policy()
        pool = None
        if trained.uses_prompt:
            pool = prompt_pool(ev, run.data.obs, run.data.demos_per_task, run.data.seed, preset,
                               progress)
        result = evaluate_policy(trained, ev, prompts=pool, workers=workers,
                                 record_dir=record_dir, progress=progress)
        return result.to_dict()

    return store.run("eval", eval_record_name(run, ev), config, compute, seed=ev.seed,
                     force=force)


# --------------------------------------------------------------------------- CLI
def build_parser() -> argparse.ArgumentParser:
    from icil_paper.cli import add_preset_arguments, positive

    p = argparse.ArgumentParser(prog="icil-paper eval",
                                description="Roll out a trained policy; store its success rate.")
    add_preset_arguments(p)
    p.add_argument("--run-dir", default=None,
                   help="folder of a training run (default: the one that --policy, --tokenizer, "
                        "--train-tasks or --suite, --source and the preset name)")
    p.add_argument("--policy", default="icrt", help="policy name, to find the default run folder")
    p.add_argument("--tokenizer", default=None, help="tokenizer name, to find the default run folder")
    p.add_argument("--tasks", nargs="+", default=None,
                   help="tasks to evaluate on (default: the tasks the policy was trained on)")
    p.add_argument("--train-tasks", nargs="+", default=None,
                   help="the training run's tasks, to find its folder (default: see --suite)")
    p.add_argument("--suite", choices=("kitchen", "maniskill"), default="kitchen",
                   help="the training run's suite when --train-tasks is not given")
    p.add_argument("--source", default="generated", help="the training run's demonstration source")
    p.add_argument("--prompt-source", default="generated", help="where prompt demonstrations come from")
    p.add_argument("--eval-seed", type=int, default=None,
                   help="evaluation seed (default: the preset's seed)")
    p.add_argument("--episodes", type=positive("--episodes"), default=None,
                   help="rollouts per task (default: the preset's eval.episodes_per_task)")
    p.add_argument("--workers", type=positive("--workers"), default=None,
                   help="parallel rollout processes (default: the preset's eval.workers)")
    p.add_argument("--max-steps", type=positive("--max-steps"), default=None,
                   help="step limit per rollout (default: the preset's, else the task's horizon)")
    p.add_argument("--record", action="store_true", help="write a rerun recording of each rollout")
    p.add_argument("--force", action="store_true", help="recompute a stored result")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    return p


def main(argv: list[str] | None = None) -> int:
    """`icil-paper eval`: evaluate a trained run on each task; one `eval` record per task."""
    from icil_paper.cli import preset_from_args
    from icil_paper.registry import check_name
    from icil_paper.results import ResultsStore, results_root
    from icil_paper.runspec import RunSpec, eval_spec, run_spec
    from icil_paper.sim import all_tasks
    from icil_paper.train.rundir import CONFIG_FILE, load_policy, run_dir_for

    args = build_parser().parse_args(argv)
    preset = preset_from_args(args)
    valid = all_tasks()
    for task in (args.tasks or []) + (args.train_tasks or []):
        check_name("task", task, valid)
    if args.run_dir:
        run_dir = Path(args.run_dir)
        config_path = run_dir / CONFIG_FILE
        if not config_path.exists():
            raise FileNotFoundError(f"{run_dir} is not a training run folder (no {CONFIG_FILE})")
        run = RunSpec.from_dict(json.loads(config_path.read_text())["spec"])
    else:
        train_tasks = args.train_tasks or list(getattr(preset.data, f"{args.suite}_tasks"))
        run = run_spec(preset, args.policy, args.tokenizer, tasks=train_tasks, source=args.source)
        run_dir = run_dir_for(run, preset.name)
    policy = load_policy(run_dir)
    store = ResultsStore(preset.name)
    workers = args.workers or preset.eval.workers
    record_dir = results_root() / preset.name / "recordings" if args.record else None
    for task in args.tasks or list(run.data.tasks):
        ev = eval_spec(preset, task, episodes=args.episodes, seed=args.eval_seed,
                       prompt_source=args.prompt_source, max_steps=args.max_steps)
        record = evaluate_run(run, ev, policy, store, preset.name, workers, record_dir,
                              force=args.force, progress=not args.quiet)
        m = record["metrics"]
        print(f"{run.label} on {task} (prompts: {args.prompt_source}): success "
              f"{m['success_rate']:.3f} [{m['ci_low']:.3f}, {m['ci_high']:.3f}] over "
              f"{m['episodes']} episodes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
