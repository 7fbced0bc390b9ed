"""From demonstrations to training batches: prompt/query sequences (ICRT) and windows (baselines).

    data = DemoSet(demos)                                           # arrays, grouped by task
    batch = prompt_query_batch(data, B, query_len, K, prompt_demos=1, rng=rng)   # ICRT
    batch = window_batch(data, B, history, K, rng)                  # the baselines

ICRT's token layout (Eq. 1, with the query's own actions in context as in ICRT's code). The
prompt is one or more demonstrations of the task, the query a window of `query_len` steps of
another demonstration of the same task:

    prompt (M steps, no loss)                        query (N steps, loss)
     o_p1  a_p1  o_p2  a_p2 ... o_pM  a_pM            o_q1  a_q1  o_q2  a_q2 ... o_qN  a_qN
                                                       │           │              │
           causal attention: each token sees          head        head           head
           itself and every token to its left        â_q1..â_q(K) â_q2..         â_qN..

The head reads only the query's observation tokens, so o_qt never sees a_qt, the action it
predicts. Short prompts and queries are padded at the end; `prompt_valid` / `query_valid`
mark real steps. Every sampler draws from a NumPy Generator.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import Tensor

from icil_paper.policies.configs import PROMPT_FROM

IMAGE_KEYS = ("rgb", "depth")
DEFAULT_LOWDIM_KEYS = ("proprio", "object")


# --------------------------------------------------------------------------- observation spec
@dataclass(frozen=True)
class ObsSpec:
    """Which observation keys a policy reads, and their sizes."""

    lowdim_keys: tuple[str, ...] = DEFAULT_LOWDIM_KEYS
    """Low-dimensional keys, concatenated in this order."""
    lowdim_dim: int = 0
    """Total width of the concatenated low-dimensional keys."""
    image: tuple[int, int, int] | None = None
    """(n_cams, H, W) of the "rgb" key, or None for state-only observations."""
    depth: bool = False
    """Whether a "depth" key (n_cams, H, W) accompanies the images (RGB-D)."""

    @property
    def keys(self) -> tuple[str, ...]:
        extra = (("rgb",) if self.image else ()) + (("depth",) if self.depth else ())
        return self.lowdim_keys + extra


def as_obs_spec(obs_dim: int | Mapping[str, Any] | ObsSpec) -> ObsSpec:
    """The ObsSpec of `make_policy`'s `obs_dim`: an int (proprio and object state widths
    summed), a mapping key -> size or shape (`{"proprio": 9, "rgb": (2, 84, 84, 3)}`) or an
    ObsSpec."""
    if isinstance(obs_dim, ObsSpec):
        return obs_dim
    if isinstance(obs_dim, (int, np.integer)):
        if obs_dim < 1:
            raise ValueError(f"obs_dim must be positive, got {obs_dim}")
        return ObsSpec(DEFAULT_LOWDIM_KEYS, int(obs_dim))
    if isinstance(obs_dim, Mapping):
        lowdim = {k: int(np.prod(v)) if isinstance(v, (tuple, list)) else int(v)
                  for k, v in obs_dim.items() if k not in IMAGE_KEYS}
        image = None
        if "rgb" in obs_dim:
            shape = tuple(int(s) for s in obs_dim["rgb"])
            if len(shape) != 4 or shape[-1] != 3:
                raise ValueError(f"rgb must be shaped (n_cams, H, W, 3), got {shape}")
            image = shape[:3]
        if "depth" in obs_dim and image is None:
            raise ValueError("a depth observation needs an rgb observation beside it")
        if not lowdim and image is None:
            raise ValueError(f"no observation keys in {dict(obs_dim)}")
        return ObsSpec(tuple(lowdim), sum(lowdim.values()), image, "depth" in obs_dim)
    raise TypeError(f"obs_dim must be an int, a mapping or an ObsSpec, got {type(obs_dim)}")


def obs_spec_from_obs(obs: Mapping[str, np.ndarray]) -> ObsSpec:
    """The ObsSpec of an observation dict of (T, ...) arrays."""
    keys = [k for k in DEFAULT_LOWDIM_KEYS + IMAGE_KEYS if k in obs]
    if not keys:
        raise ValueError(f"observation has none of the keys {DEFAULT_LOWDIM_KEYS + IMAGE_KEYS}; "
                         f"it has {sorted(obs)}")
    return as_obs_spec({k: tuple(np.shape(obs[k])[1:]) for k in keys})


# --------------------------------------------------------------------------- demonstrations
def check_demo(i: int, demo: Any, keys: Sequence[str], action_dim: int,
               what: str = "demonstration") -> None:
    """ValueError naming what is wrong with demonstration `i`: its actions (T, A), or one of
    its observations `keys` (missing, or of another length)."""
    name = f"{what} {i} ({getattr(demo, 'task', '?')})"
    actions = np.asarray(demo.actions)
    if actions.ndim != 2 or len(actions) == 0:
        raise ValueError(f"{'empty' if actions.size == 0 else 'misshaped'} {name}: actions must "
                         f"be a non-empty (T, A) array, got shape {actions.shape}")
    if actions.shape[1] != action_dim:
        raise ValueError(f"wrong action dimension in {name}: {actions.shape[1]}-dimensional "
                         f"actions, expected {action_dim}")
    if not np.isfinite(actions).all():
        raise ValueError(f"{name}: actions contain NaN or inf")
    for k in keys:
        if k not in demo.obs:
            raise ValueError(f"{name}: observation key {k!r} is missing (it has {sorted(demo.obs)})")
        if len(demo.obs[k]) != len(actions):
            raise ValueError(f"{name}: obs[{k!r}] has {len(demo.obs[k])} steps but there are "
                             f"{len(actions)} actions")


class DemoSet:
    """Demonstrations held as arrays, grouped by task, ready to be sampled into batches.

    demos: Demo-like objects (`actions` (T, A), `obs` {key: (T, ...)}, `task`, `instruction`);
    spec: the observation keys to keep (default: the first demo's).
    """

    def __init__(self, demos: Sequence[Any], spec: ObsSpec | None = None):
        demos = list(demos)
        if not demos:
            raise ValueError("no demonstrations given")
        self.spec = spec or obs_spec_from_obs(demos[0].obs)
        self.action_dim = int(np.asarray(demos[0].actions).shape[1])
        for i, d in enumerate(demos):
            check_demo(i, d, self.spec.keys, self.action_dim)
        self.actions = [np.asarray(d.actions, np.float32) for d in demos]
        self.obs = [{k: _as_stored(k, d.obs[k]) for k in self.spec.keys} for d in demos]
        self.tasks = [str(getattr(d, "task", "task")) for d in demos]
        self.instructions = [str(getattr(d, "instruction", "") or "") for d in demos]
        self.lengths = np.array([len(a) for a in self.actions])
        self.by_task: dict[str, list[int]] = {}
        for i, t in enumerate(self.tasks):
            self.by_task.setdefault(t, []).append(i)
        self._cum = np.concatenate([[0], np.cumsum(self.lengths)])

    def __len__(self) -> int:
        return len(self.actions)

    @property
    def n_steps(self) -> int:
        return int(self.lengths.sum())

    def all_obs(self) -> dict[str, np.ndarray]:
        """Every step's observation, concatenated over demonstrations: key -> (sum T, ...)."""
        return {k: np.concatenate([o[k] for o in self.obs]) for k in self.spec.keys}

    def step_index(self, flat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Map flat step indices (over all demos) to (demo index, step index)."""
        demo = np.searchsorted(self._cum, flat, side="right") - 1
        return demo, flat - self._cum[demo]


def _as_stored(key: str, x: np.ndarray) -> np.ndarray:
    return np.asarray(x).astype(np.uint8 if key == "rgb" else np.float32, copy=False)


# --------------------------------------------------------------------------- helpers
def _take(x: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """x[idx] with idx clamped into range (edge padding)."""
    return x[np.clip(idx, 0, len(x) - 1)]


def _stack_obs(rows: list[dict[str, np.ndarray]]) -> dict[str, Tensor]:
    return {k: torch.from_numpy(np.stack([r[k] for r in rows])) for k in rows[0]}


def _stack(rows: list[dict[str, Any]], key: str, length: int | None = None) -> Any:
    """The rows' `key` stacked (B, ...) ({key: (B, ...)} for observations), each row first
    edge-padded to `length` steps (None: as they are)."""
    items = [r[key] for r in rows]
    if isinstance(items[0], dict):
        return _stack_obs([{k: _pad_end(v, length) if length else v for k, v in i.items()}
                           for i in items])
    return torch.from_numpy(np.stack([_pad_end(i, length) if length else i for i in items]))


def _pad_end(x: np.ndarray, length: int) -> np.ndarray:
    """Pad (T, ...) to (length, ...) by repeating the last row."""
    return _take(x, np.arange(length))


def chunk_targets(actions: np.ndarray, steps: np.ndarray, chunk: int) -> tuple[np.ndarray, np.ndarray]:
    """Future actions a_t .. a_(t+K-1) for each step t: (len(steps), K, A) and a validity mask."""
    idx = steps[:, None] + np.arange(chunk)[None, :]  # (N, K)
    valid = idx < len(actions)
    return _take(actions, idx), valid


# --------------------------------------------------------------------------- ICRT batches
def prompt_query_batch(data: DemoSet, batch_size: int, query_len: int, chunk_size: int,
                       prompt_demos: int, rng: np.random.Generator,
                       action_context: int = 0, query_start: str = "random",
                       prompt_from: str = "same_task") -> dict[str, Any]:
    """Sample B (prompt, query) pairs (see the module docstring).

    Returns a dict of tensors (padded; B batch, M prompt steps, N query steps, K chunk):
        prompt_obs {key: (B, M, ...)}, prompt_actions (B, M, A), prompt_valid (B, M) bool,
        query_obs {key: (B, N, ...)}, query_actions (B, N, A), query_valid (B, N) bool,
        targets (B, N, K, A), target_valid (B, N, K) bool, instruction [B strings], and with
        `action_context` = c > 0 query_action_context (B, c, A), the c actions before each
        query window (edge-padded).
    The prompt is `prompt_demos` other demonstrations of the query's task (`prompt_from=
    "minibatch"`: of the same random minibatch). The query window holds `query_len` steps
    (0: the whole episode) and starts at random or at step 0 (`query_start`).
    """
    if prompt_demos < 1:
        raise ValueError(f"prompt_demos must be at least 1, got {prompt_demos}")
    if query_len < 0 or query_start not in ("random", "episode_start"):
        raise ValueError(f"query_len must be >= 0 and query_start 'random' or 'episode_start', "
                         f"got {query_len} and {query_start!r}")
    if prompt_from not in PROMPT_FROM:
        raise ValueError(f"prompt_from must be one of {', '.join(PROMPT_FROM)}, got "
                         f"{prompt_from!r}")
    pairs = (_minibatch_pairs(len(data), batch_size, prompt_demos, rng)
             if prompt_from == "minibatch" else None)
    rows = []
    for b in range(batch_size):
        if pairs is not None:
            q, prompt = pairs[b]
        else:
            q = int(rng.integers(len(data)))
            same = [i for i in data.by_task[data.tasks[q]] if i != q] or [q]
            chosen = rng.choice(len(same), size=prompt_demos, replace=len(same) < prompt_demos)
            prompt = [same[int(c)] for c in chosen]
        T = int(data.lengths[q])
        n = T if query_len == 0 else min(query_len, T)
        start = int(rng.integers(0, T - n + 1)) if query_start == "random" else 0
        steps = np.arange(start, start + n)
        targets, tvalid = chunk_targets(data.actions[q], steps, chunk_size)
        rows.append({
            "prompt_obs": {k: np.concatenate([data.obs[p][k] for p in prompt]) for k in data.spec.keys},
            "prompt_actions": np.concatenate([data.actions[p] for p in prompt]),
            "query_obs": {k: v[steps] for k, v in data.obs[q].items()},
            "query_actions": data.actions[q][steps],
            "targets": targets, "target_valid": tvalid,
            "instruction": data.instructions[q],
            "context": _take(data.actions[q], np.arange(start - action_context, start)),
        })
    M = max(len(r["prompt_actions"]) for r in rows)
    N = max(len(r["query_actions"]) for r in rows)
    batch = {
        "prompt_valid": torch.tensor(np.stack([np.arange(M) < len(r["prompt_actions"]) for r in rows])),
        "query_valid": torch.tensor(np.stack([np.arange(N) < len(r["query_actions"]) for r in rows])),
        **{k: _stack(rows, k, M) for k in ("prompt_obs", "prompt_actions")},
        **{k: _stack(rows, k, N) for k in ("query_obs", "query_actions", "targets")},
        "instruction": [r["instruction"] for r in rows],
    }
    if action_context > 0:
        batch["query_action_context"] = _stack(rows, "context")
    batch["target_valid"] = _stack(rows, "target_valid", N) & batch["query_valid"][:, :, None]
    return batch


def _minibatch_pairs(n_demos: int, batch_size: int, prompt_demos: int,
                    rng: np.random.Generator) -> list[tuple[int, list[int]]]:
    # the official code's pairing: of (P + 1) B random demonstrations, the first P B prompt
    # the last B, whatever their tasks
    n = (prompt_demos + 1) * batch_size
    drawn = rng.choice(n_demos, size=n, replace=n_demos < n)
    prompts = drawn[:prompt_demos * batch_size].reshape(batch_size, prompt_demos)
    queries = drawn[prompt_demos * batch_size:]
    return [(int(q), [int(p) for p in ps]) for q, ps in zip(queries, prompts, strict=True)]


# --------------------------------------------------------------------------- baseline windows
def window_batch(data: DemoSet, batch_size: int, history: int, chunk_size: int,
                 rng: np.random.Generator) -> dict[str, Any]:
    """Sample B steps uniformly over all demonstration steps, with history and future actions.

    The window of a step t of one demonstration (BC-Transformer, ACT, MCR)::

        history (H steps, edge-padded at the start)      future actions (K steps)
        o_(t-H+1) ... o_(t-1)  o_t                     a_t  a_(t+1) ... a_(t+K-1)
        a_(t-H+1) ... a_(t-1)  a_t   (per-step targets)   (masked past the episode's end)

    Returns: obs {key: (B, H, ...)}, obs_valid (B, H) (False for padded history), actions
    (B, H, A), targets (B, K, A) and target_valid (B, K), instruction [B], index (demo
    indices (B,), step indices (B,)) as NumPy arrays.
    """
    flat = rng.integers(0, data.n_steps, size=batch_size)
    demo_idx, step_idx = data.step_index(flat)
    rows = []
    for d, t in zip(demo_idx.tolist(), step_idx.tolist(), strict=True):
        hist = np.arange(t - history + 1, t + 1)
        targets, tvalid = chunk_targets(data.actions[d], np.array([t]), chunk_size)
        rows.append({"obs": {k: _take(v, hist) for k, v in data.obs[d].items()},
                     "obs_valid": hist >= 0, "actions": _take(data.actions[d], hist),
                     "targets": targets[0], "target_valid": tvalid[0]})
    return {**{k: _stack(rows, k) for k in ("obs", "obs_valid", "actions", "targets", "target_valid")},
            "instruction": [data.instructions[d] for d in demo_idx.tolist()],
            "index": (demo_idx, step_idx)}


def batch_to(batch: Mapping[str, Any], device: torch.device | str) -> dict[str, Any]:
    """Move every tensor of a (nested) batch dict to `device`."""
    return {k: v.to(device) if isinstance(v, Tensor) else
            batch_to(v, device) if isinstance(v, Mapping) else v for k, v in batch.items()}


def obs_batch(obs: Mapping[str, np.ndarray], spec: ObsSpec) -> dict[str, Tensor]:
    """An environment observation -> {key: (1, 1, ...)}."""
    out = {}
    for k in spec.keys:
        if k not in obs:
            raise ValueError(f"observation key {k!r} is missing (the observation has "
                             f"{sorted(obs)}; the policy reads {list(spec.keys)})")
        x = np.asarray(obs[k])
        if x.dtype.kind == "f" and not np.isfinite(x).all():
            raise ValueError(f"observation {k!r} contains NaN or inf; a policy acting on it "
                             "would return NaN actions (check the environment's state)")
        out[k] = torch.from_numpy(np.ascontiguousarray(_as_stored(k, x)))[None, None]
    return out


__all__ = ["DemoSet", "prompt_query_batch",
           "window_batch", "chunk_targets", "batch_to", "obs_batch", "IMAGE_KEYS"]
