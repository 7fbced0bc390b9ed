"""The rollout engine: many episodes of many tasks in this process, N environments stepped
in lockstep with one batched policy forward pass per step.

    from icil_paper.eval.rollouts import Episode, run_episodes
    episodes = [Episode(spec=0, task="kitchen/open_drawer", index=i, seed=s, prompt=(2,))
                for i, s in enumerate(seeds)]
    results = run_episodes(policy, episodes, prompts={0: pool}, obs="state")

Episodes are interleaved over evaluations and cut into lockstep groups of at most
`batch_size` (`group_episodes`); a group's outcomes depend on its episodes alone, so for a
given batch size the results are the same bit for bit.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm.auto import tqdm

from icil_paper.metrics import action_second_difference, motion_smoothness
from icil_paper.seeding import cpu_threads
from icil_paper.sim import make_env, object_position
from icil_paper.timing import phase
from icil_paper.viz.recording import record_episode

MAX_BATCH = 16
"""Largest default group (beyond it stepping the envs in turn dwarfs the forward pass)."""


@dataclass(frozen=True)
class Episode:
    """One planned rollout."""

    spec: int
    """Which evaluation it belongs to (an index into the caller's specs; keys `prompts`)."""
    task: str
    index: int
    """Its index within its evaluation (episode 0, 1, ...)."""
    seed: int
    """The env seed it starts from."""
    prompt: tuple[int, ...] = ()
    """Indices into its evaluation's prompt pool (empty: no prompt)."""
    max_steps: int | None = None
    """Step limit; None: the env's horizon."""
    env_options: tuple[tuple[str, Any], ...] = ()
    """Options of its env beyond the call's (`EnvSetup.options`), as sorted (name, value)."""


@dataclass(frozen=True)
class EnvSetup:
    """How every env of a call is built: `factory(task, obs=obs, seed=seed, **options)`,
    with an episode's own `env_options` added."""

    obs: str = "state"
    """Observation kind: state, rgb or rgbd."""
    options: tuple[tuple[str, Any], ...] = ()
    """Extra keyword options of the factory, as sorted (name, value) pairs."""
    factory: Callable[..., Any] | None = None
    """A picklable callable; None: `icil_paper.sim.make_env`."""

    def make(self, task: str, seed: int, options: tuple[tuple[str, Any], ...] = ()) -> Any:
        factory = self.factory or make_env
        return factory(task, obs=self.obs, seed=seed, **{**dict(self.options), **dict(options)})


# --------------------------------------------------------------------------- lockstep rollouts
def rollout_batch(policy: Any, envs: Sequence[Any], seeds: Sequence[int],
                  prompts: Sequence[Sequence[Any] | None] | None = None,
                  max_steps: Sequence[int | None] | int | None = None,
                  keep_trace: bool = False) -> list[dict[str, Any]]:
    """Run len(envs) episodes in lockstep, one `policy.select_actions` per step.

    Episode b starts from `seeds[b]` with prompt `prompts[b]` and ends on success,
    termination, truncation or `max_steps[b]` (default: the env's horizon). Returns per
    episode {"success", "steps", "return", "wall_time_s", "actions" (T, A) clipped to
    [-1, 1], "eef_path" (T + 1, 3) or None, "dt"} and, with `keep_trace`, "obs", "final_obs".
    """
    n = len(envs)
    if len(seeds) != n:
        raise ValueError(f"{n} envs but {len(seeds)} seeds")
    prompts = [None] * n if prompts is None else list(prompts)
    limits = list(max_steps) if isinstance(max_steps, (list, tuple)) else [max_steps] * n
    if len(prompts) != n or len(limits) != n:
        raise ValueError(f"{n} envs need {n} prompts and step limits")
    start = time.perf_counter()
    limits = [int(m or env.horizon) for m, env in zip(limits, envs, strict=True)]
    with phase("eval.reset"):
        obs = [env.reset(seed=int(seed))[0] for env, seed in zip(envs, seeds, strict=True)]
        paths: list[list[np.ndarray] | None] = [_first_position(env) for env in envs]
    uses_prompt = getattr(policy, "uses_prompt", False)
    with phase("eval.policy"):  # the prompt's prefill
        policy.reset_batch([list(p) if uses_prompt and p is not None else None
                            for p in prompts], [getattr(env, "instruction", "") for env in envs])
    steps, success, total = [0] * n, [False] * n, [0.0] * n
    ended = [0.0] * n
    seen: list[list[Any]] = [[] for _ in range(n)]
    taken: list[list[np.ndarray]] = [[] for _ in range(n)]
    running = list(range(n))
    while running:
        with phase("eval.policy"):
            actions = np.asarray(policy.select_actions([obs[i] for i in running], rows=running))
            actions = np.clip(actions, -1.0, 1.0).astype(np.float32)
        still = []
        for action, i in zip(actions, running, strict=True):
            if keep_trace:
                seen[i].append(obs[i])
            taken[i].append(action)
            with phase("eval.sim"):
                obs[i], reward, terminated, truncated, info = envs[i].step(action)
            if paths[i] is not None:
                with phase("eval.motion"):
                    paths[i].append(envs[i].eef_position())
            steps[i] += 1
            total[i] += float(reward)
            if info.get("success"):
                success[i] = True
            elif not (terminated or truncated or steps[i] >= limits[i]):
                still.append(i)
                continue
            ended[i] = time.perf_counter() - start
        running = still
    out = []
    for i, env in enumerate(envs):
        row: dict[str, Any] = {
            "success": success[i], "steps": steps[i], "return": round(total[i], 6),
            "wall_time_s": round(ended[i], 3),
            "actions": np.asarray(taken[i], np.float32).reshape(-1, env.action_dim),
            "eef_path": None if paths[i] is None else np.asarray(paths[i], np.float64),
            "dt": None if paths[i] is None else float(env.control_dt)}
        if keep_trace:
            row.update(obs=seen[i], final_obs=obs[i])
        out.append(row)
    return out


def _first_position(env: Any) -> list[np.ndarray] | None:
    read = getattr(env, "eef_position", None)
    if read is None:
        return None
    try:
        return [np.asarray(read(), np.float64)]
    except NotImplementedError:
        return None


def motion_record(out: Mapping[str, Any]) -> dict[str, float | None]:
    """`ldlj`, `sparc` and `action_jerk` of one `rollout_batch` output; None where undefined."""
    if out.get("eef_path") is None:
        values = {"ldlj": math.nan, "sparc": math.nan,
                  "action_jerk": action_second_difference(out["actions"])}
    else:
        values = motion_smoothness(out["eef_path"], out["actions"], out["dt"])
    return {k: float(f"{v:.7g}") if math.isfinite(v) else None for k, v in values.items()}


def rollout_policy(policy: Any, env: Any, seed: int, prompt: Sequence[Any] | None = None,
            max_steps: int | None = None, keep_trace: bool = False) -> dict[str, Any]:
    """Run one episode from `seed` with `prompt`; `rollout_batch`'s dict without wall time."""
    out = rollout_batch(policy, [env], [seed], [prompt], [max_steps], keep_trace)[0]
    out.pop("wall_time_s")
    return out


def record_rollout(policy: Any, task: str, ep: Mapping[str, Any], trace: Mapping[str, Any],
                   record_dir: str | Path) -> str:
    """Write one rollout (`rollout_policy(..., keep_trace=True)`, episode {"index", "seed"})
    as `<record_dir>/<task>__seed<seed>.rrd`; return that path, or the `.png` without rerun."""
    actions = np.asarray(trace["actions"], np.float32)
    latents = None
    tokenizer = getattr(policy, "tokenizer", None)
    if tokenizer is not None and len(actions):
        with torch.no_grad():  # the latent action tokens of the executed actions
            x = torch.from_numpy(actions)[None].to(getattr(policy, "device", "cpu"))
            latents = tokenizer(x).embeddings[0].cpu().numpy()
    path = Path(record_dir) / f"{task.replace('/', '-')}__seed{ep['seed']}.rrd"
    title = (f"{getattr(policy, 'name', 'policy')} on {task}, episode {ep['index']} "
             f"(env seed {ep['seed']}): {'success' if trace['success'] else 'failure'}")

    out = record_episode(path, trace["obs"], actions, latents=latents, title=title,
                         object_position=object_position(task))
    return str(out["rrd"] or out["png"])


# --------------------------------------------------------------------------- groups
def default_batch_size(episodes: Sequence[Episode], max_batch: int = MAX_BATCH) -> int:
    """`run_episodes`'s default batch size: at most one episode per evaluation in a group and
    at most `max_batch`, in groups of nearly equal size."""
    n = len(episodes)
    if n == 0:
        return 1
    widest = max(1, min(int(max_batch), len({e.spec for e in episodes})))
    return max(1, math.ceil(n / math.ceil(n / widest)))


def group_episodes(episodes: Sequence[Episode], batch_size: int) -> list[list[Episode]]:
    """Episodes interleaved over evaluations (episode 0 of every spec, then 1, ...), cut into
    ceil(n / batch_size) consecutive groups of nearly equal size."""
    if batch_size < 1:
        raise ValueError(f"batch_size must be at least 1, got {batch_size}")
    order = sorted(episodes, key=lambda e: (e.index, e.spec))
    n = len(order)
    count = math.ceil(n / batch_size)
    bounds = [round(k * n / count) for k in range(count + 1)] if count else [0]
    return [order[a:b] for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


# --------------------------------------------------------------------------- one group
@dataclass
class GroupJob:
    """One lockstep group (`run_group`): what to run and with what."""

    episodes: list[Episode]
    prompts: dict[int, dict[int, Any]]
    """The prompt demonstrations they use: {spec: {pool index: demonstration}}."""
    policy: Any
    env: EnvSetup
    record_dir: str | None = None
    """Write a rerun recording of each rollout there."""


def group_jobs(episodes: Sequence[Episode], prompts: Mapping[int, Sequence[Any]], policy: Any,
               env: EnvSetup, batch_size: int, record_dir: str | None = None
               ) -> list[GroupJob]:
    """The jobs of `group_episodes(episodes, batch_size)`, each carrying only its prompts."""
    jobs = []
    for group in group_episodes(episodes, batch_size):
        used: dict[int, dict[int, Any]] = {}
        for ep in group:
            for j in ep.prompt:
                used.setdefault(ep.spec, {})[j] = prompts[ep.spec][j]
        jobs.append(GroupJob(group, used, policy, env, record_dir))
    return jobs


@dataclass
class WorkerState:
    """The environments a process keeps between groups, by setup and task."""

    envs: dict[tuple[Any, ...], list[Any]] = field(default_factory=dict)

    def envs_for(self, setup: EnvSetup, episodes: Sequence[Episode]) -> list[Any]:
        """One env per episode, built where this worker has too few for a task."""
        out, used = [], {}
        for ep in episodes:
            key = self.env_key(setup, ep)
            pool = self.envs.setdefault(key, [])
            k = used.get(key, 0)
            if k == len(pool):
                with phase("eval.env_build"):
                    pool.append(setup.make(ep.task, ep.seed, ep.env_options))
            out.append(pool[k])
            used[key] = k + 1
        return out

    @staticmethod
    def env_key(setup: EnvSetup, ep: Episode) -> tuple[Any, ...]:
        return (setup.factory, setup.obs, repr(setup.options), ep.task, repr(ep.env_options))

    def trim(self, setup: EnvSetup, episodes: Sequence[Episode], most: int) -> None:
        """Close the envs that `episodes` do not use while more than `most` are kept."""
        needed = {self.env_key(setup, ep) for ep in episodes}
        for key in [k for k in self.envs if k not in needed]:
            if sum(map(len, self.envs.values())) <= most:
                break
            for env in self.envs.pop(key):
                env.close()

    def close(self) -> None:
        for pool in self.envs.values():
            for env in pool:
                env.close()
        self.envs.clear()


def run_group(state: WorkerState, job: GroupJob) -> list[dict[str, Any]]:
    """Roll out one group in this process; one result dict per episode, in group order."""
    policy = job.policy
    if isinstance(policy, torch.nn.Module):
        policy.eval()
    envs = state.envs_for(job.env, job.episodes)
    prompts = [[job.prompts[ep.spec][j] for j in ep.prompt] if ep.prompt else None
               for ep in job.episodes]
    outs = rollout_batch(policy, envs, [ep.seed for ep in job.episodes], prompts,
                         [ep.max_steps for ep in job.episodes],
                         keep_trace=job.record_dir is not None)
    results = []
    for ep, out in zip(job.episodes, outs, strict=True):
        with phase("eval.motion"):
            motion = motion_record(out)
        row = {"episode": ep.index, "seed": ep.seed, "success": bool(out["success"]),
               "steps": int(out["steps"]), "return": out["return"], "prompt": list(ep.prompt),
               "wall_time_s": out["wall_time_s"], **motion}
        if job.record_dir is not None:
            row["recording"] = record_rollout(policy, ep.task, {"index": ep.index,
                                                                "seed": ep.seed},
                                              out, job.record_dir)
        results.append(row)
    return results


KEPT_ENVS = 26
"""Most environments a process keeps between `run_episodes(..., keep_envs=True)` calls
(one ICRT cell's); beyond it the envs a call does not use are closed."""


@functools.cache
def worker_state() -> WorkerState:
    """This process's WorkerState, the envs it keeps between `keep_envs` calls (`close()`
    it to start from none)."""
    return WorkerState()


# --------------------------------------------------------------------------- many episodes
def run_episodes(policy: Any, episodes: Sequence[Episode],
                 prompts: Mapping[int, Sequence[Any]] | None = None, obs: str = "state",
                 batch_size: int | None = None, env_factory: Callable[..., Any] | None = None,
                 env_options: Mapping[str, Any] | None = None, record_dir: str | Path | None = None,
                 progress: bool = True, desc: str = "rollouts",
                 keep_envs: bool = False) -> list[dict[str, Any]]:
    """Run every episode in this process; one result dict per episode, in order: episode,
    seed, success, steps, return, prompt, wall_time_s, `motion_record`'s measures and, with
    `record_dir`, recording.

    Episode e's prompt is [prompts[e.spec][j] for j in e.prompt]; `keep_envs` keeps the envs
    for the next call (at most `KEPT_ENVS`), which does not change results.
    """
    if not episodes:
        return []
    batch = int(batch_size) if batch_size is not None else default_batch_size(episodes)
    setup = EnvSetup(obs, tuple(sorted(dict(env_options or {}).items())), env_factory)
    if record_dir is not None:
        Path(record_dir).mkdir(parents=True, exist_ok=True)
        record_dir = str(record_dir)
    prompts = dict(prompts or {})
    bar = tqdm(total=len(episodes), desc=desc, unit="episode", disable=not progress,
               leave=False)
    by_episode: dict[tuple[int, int], dict[str, Any]] = {}
    is_module = isinstance(policy, torch.nn.Module)
    was_training = is_module and policy.training
    if is_module:
        policy.eval()
    state = worker_state() if keep_envs else WorkerState()
    state.trim(setup, episodes, KEPT_ENVS)
    try:
        with cpu_threads(1):  # small batched steps gain nothing from a thread pool
            for job in group_jobs(episodes, prompts, policy, setup, batch, record_dir):
                for ep, row in zip(job.episodes, run_group(state, job), strict=True):
                    by_episode[ep.spec, ep.index] = row
                bar.update(len(job.episodes))
    finally:
        if keep_envs:  # keep what this call used, the likeliest next
            state.trim(setup, episodes, KEPT_ENVS)
        else:
            state.close()
        bar.close()
        if is_module:
            policy.train(was_training)
    return [by_episode[ep.spec, ep.index] for ep in episodes]
