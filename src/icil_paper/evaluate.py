"""Rollouts that turn a trained policy into a success rate, and `icil-paper eval`.

    from icil_paper.evaluate import evaluate_policy
    result = evaluate_policy(policy, "kitchen/open_drawer", "small", prompt_source="generated",
                             episodes=10, seed=0, workers=2)
    result["success_rate"], result["ci_low"], result["ci_high"], result["per_episode"]

Each episode i (of `episodes`) is fixed by the evaluation seed alone:

- its environment seed is `EVAL_SEED_BASE + 10_000 * seed + i` (`icil_paper.data`), above
  every seed demonstrations are generated with, so rollouts start from unseen scenes;
- for an in-context policy, its prompt is `PolicyConfig.prompt_demos` demonstrations of
  the task drawn from `prompt_source` with `np.random.default_rng([seed, i])`;
- it runs until the task reports success, the episode ends, or `max_steps` (default: the
  preset's `eval.max_steps`, else the task's horizon). Actions are clipped to [-1, 1].

So the same seed gives the same episodes whether they run in one process or many. With
`workers > 1` the episodes are split over spawned processes; each builds its own
environment and its own copy of the policy from the policy's constructor arguments and
state dict. The success rate comes with a Wilson 95% confidence interval.

With `record=True` each rollout is written as a rerun recording (the observed scene state:
end effector and object; camera frames for image observations; the executed actions; and,
when the policy has an action tokenizer, its latent tokens of those actions) through
`icil_paper.recording.record_episode`, under `results/<preset>/recordings/` by default.
"""

from __future__ import annotations

import argparse
import io
import json
import math
import sys
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import torch

from icil_paper.config import PRESET_NAMES, Preset, active_preset_name, get_preset

Z_95 = 1.959963984540054


def wilson_interval(successes: int, n: int, z: float = Z_95) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion (95% by default); (0, 1) for n = 0."""
    if n <= 0:
        return 0.0, 1.0
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return max(0.0, centre - half), min(1.0, centre + half)


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
    torch.save({"spec": policy.spec, "state_dict": policy.state_dict()}, buf)
    return buf.getvalue()


def _policy_from_blob(blob: bytes) -> Any:
    from icil_paper.policies.base import build_policy

    state = torch.load(io.BytesIO(blob), map_location="cpu", weights_only=False)
    policy = build_policy(state["spec"])
    policy.load_state_dict(state["state_dict"])
    return policy.eval()


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
    from icil_paper.sim import OBJECT_POSITION

    out = record_episode(path, trace["obs"], actions, latents=latents, title=title,
                         object_position=OBJECT_POSITION.get(task.split("/", 1)[0]))
    return str(out["rrd"] or out["png"])


def _worker(blob: bytes, task: str, kind: str, plan: list[dict[str, Any]],
            prompts: Mapping[int, Any], max_steps: int | None, record_dir: str | None,
            env_options: Mapping[str, Any], env_factory: Callable[..., Any] | None
            ) -> list[dict[str, Any]]:
    torch.set_num_threads(1)
    return _run_episodes(_policy_from_blob(blob), task, kind, plan, prompts, max_steps,
                         record_dir, env_options, env_factory)


# --------------------------------------------------------------------------- evaluation
def evaluate_policy(policy: Any, task: str, preset: Preset | str | None = None,
                    prompt_source: str = "generated", episodes: int | None = None,
                    seed: int | None = None, workers: int | None = None, record: bool = False,
                    max_steps: int | None = None, prompts: Sequence[Any] | None = None,
                    record_dir: str | Path | None = None, progress: bool = True,
                    env_options: Mapping[str, Any] | None = None,
                    env_factory: Callable[..., Any] | None = None) -> dict[str, Any]:
    """Success rate of `policy` on `task` over `episodes` rollouts (see the module docstring).

    Args:
        policy: a trained policy (`icil_paper.policies`).
        task: a task name of `icil_paper.sim.TASKS`.
        preset: a Preset or preset name (defaults for episodes, workers, max_steps, record).
        prompt_source: where prompt demonstrations come from ("generated" or "human").
        episodes, seed, workers, max_steps: override the preset's values.
        record: write a rerun recording of each rollout under `record_dir`.
        prompts: prompt demonstrations to draw from instead of loading `prompt_source`.
        env_options: extra keyword options for `make_env`.
        env_factory: a picklable callable (task, obs=, seed=, **env_options) -> env used
            instead of `icil_paper.sim.make_env` (e.g. `policies.synthetic.make_synthetic_env`).

    Returns a dict: task, prompt_source, seed, episodes, successes, success_rate, ci_low,
    ci_high (Wilson 95%), mean_steps, max_steps, per_episode (list of dicts: episode, seed,
    success, steps, return, prompt (indices into the prompt pool), wall_time_s, recording).
    """
    preset = preset if isinstance(preset, Preset) else get_preset(preset)
    ec = preset.eval
    episodes = ec.episodes_per_task if episodes is None else int(episodes)
    seed = preset.seed if seed is None else int(seed)
    workers = ec.workers if workers is None else int(workers)
    max_steps = ec.max_steps if max_steps is None else max_steps
    record = record or ec.record
    if episodes < 1:
        raise ValueError(f"episodes must be at least 1, got {episodes}")

    pool: list[Any] = []
    if policy.uses_prompt:
        if prompts is None:
            from icil_paper.data import ensure_demos, load_demos

            prompts = load_demos(ensure_demos(preset, task, prompt_source, progress=progress,
                                              obs=obs_kind(policy)))
        pool = [d for d in prompts if getattr(d, "task", task) == task] or list(prompts)
        if not pool:
            raise ValueError(f"no prompt demonstrations for {task} from {prompt_source!r}")
    k = policy.config.prompt_demos
    plan = []
    for i in range(episodes):
        chosen: list[int] = []
        if pool:
            rng = np.random.default_rng([seed, i])
            chosen = [int(j) for j in rng.choice(len(pool), size=k, replace=len(pool) < k)]
        plan.append({"index": i, "seed": episode_seed(seed, i), "prompt": chosen})
    used = {j: pool[j] for ep in plan for j in ep["prompt"]}
    if record:
        from icil_paper.results import results_root

        record_dir = str(record_dir or results_root() / preset.name / "recordings")
        Path(record_dir).mkdir(parents=True, exist_ok=True)
    else:
        record_dir = None
    kind, env_options = obs_kind(policy), dict(env_options or {})

    start = time.perf_counter()
    was_training = policy.training
    policy.eval()
    if workers <= 1 or episodes <= 1:
        from icil_paper.train import cpu_threads

        with cpu_threads(1):  # one episode at a time gains nothing from a thread pool
            per_episode = _run_episodes(policy, task, kind, plan, used, max_steps, record_dir,
                                        env_options, env_factory, progress=progress)
    else:
        import multiprocessing as mp

        from tqdm.auto import tqdm

        blob = _policy_blob(policy)
        n = min(workers, episodes)
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

    successes = sum(r["success"] for r in per_episode)
    lo, hi = wilson_interval(successes, len(per_episode))
    return {"task": task, "prompt_source": prompt_source if policy.uses_prompt else None,
            "seed": seed, "episodes": len(per_episode), "successes": int(successes),
            "success_rate": successes / len(per_episode), "ci_low": lo, "ci_high": hi,
            "mean_steps": float(np.mean([r["steps"] for r in per_episode])),
            "max_steps": max_steps, "workers": workers,
            "wall_time_s": round(time.perf_counter() - start, 3), "per_episode": per_episode}


def evaluate_tasks(policy: Any, tasks: Sequence[str], preset: Preset | str | None = None,
                   **kwargs: Any) -> dict[str, Any]:
    """`evaluate_policy` on each task; returns {"tasks": {task: result}, "average": mean rate}."""
    results = {t: evaluate_policy(policy, t, preset, **kwargs) for t in tasks}
    return {"tasks": results,
            "average": float(np.mean([r["success_rate"] for r in results.values()]))}


# --------------------------------------------------------------------------- CLI
def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="icil-paper eval",
                                description="Roll out a trained policy; store its success rate.")
    p.add_argument("--preset", choices=PRESET_NAMES, default=None,
                   help="preset (default: $ICIL_PRESET or small)")
    p.add_argument("--seed", type=int, default=None, help="evaluation seed (default: preset seed)")
    p.add_argument("--run-dir", default=None,
                   help="folder of a training run (default: the one that --policy, --tokenizer, "
                        "--train-tasks or --suite, and --source name, trained with the preset's seed)")
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
    p.add_argument("--episodes", type=int, default=None, help="rollouts per task")
    p.add_argument("--workers", type=int, default=None, help="parallel rollout processes")
    p.add_argument("--max-steps", type=int, default=None, help="step limit per rollout")
    p.add_argument("--record", action="store_true", help="write a rerun recording of each rollout")
    p.add_argument("--force", action="store_true", help="recompute a stored result")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    return p


def main(argv: list[str] | None = None) -> int:
    """`icil-paper eval`: evaluate a trained run on each task; one `eval` record per task."""
    from icil_paper.policies import policy_label
    from icil_paper.results import ResultsStore
    from icil_paper.train import CONFIG_FILE, default_run_dir, load_policy, policy_digest

    args = build_parser().parse_args(argv)
    preset = get_preset(active_preset_name(args.preset), seed=args.seed)
    if args.run_dir:
        run_dir = Path(args.run_dir)
    else:
        train_preset = get_preset(preset.name)  # runs are named by the training seed
        train_tasks = args.train_tasks or list(getattr(preset.data, f"{args.suite}_tasks"))
        run_dir = default_run_dir(train_preset, args.policy, args.tokenizer, train_tasks, args.source)
    policy = load_policy(run_dir)
    run_config = json.loads((run_dir / CONFIG_FILE).read_text())
    tasks = args.tasks or run_config["tasks"]
    label = run_config.get("label") or policy_label(run_config["policy"], run_config["tokenizer"])
    store = ResultsStore(preset.name)
    digest = policy_digest(policy)
    for task in tasks:
        config = {"label": label, "policy": run_config["policy"], "tokenizer": run_config["tokenizer"],
                  "train_tasks": run_config["tasks"], "train_source": run_config["source"],
                  "train_seed": run_config["seed"], "policy_digest": digest, "task": task,
                  "prompt_source": args.prompt_source, "seed": preset.seed,
                  "episodes": args.episodes or preset.eval.episodes_per_task,
                  "max_steps": args.max_steps or preset.eval.max_steps}

        def compute(task=task, config=config):
            r = evaluate_policy(policy, task, preset, prompt_source=args.prompt_source,
                                episodes=config["episodes"], seed=preset.seed, workers=args.workers,
                                record=args.record, max_steps=args.max_steps,
                                progress=not args.quiet)
            return {k: v for k, v in r.items() if k != "task"}

        record = store.run("eval", f"{label}__{task}__{args.prompt_source}", config, compute,
                           seed=preset.seed, force=args.force)
        m = record["metrics"]
        print(f"{label} on {task} (prompts: {args.prompt_source}): success {m['success_rate']:.3f} "
              f"[{m['ci_low']:.3f}, {m['ci_high']:.3f}] over {m['episodes']} episodes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
