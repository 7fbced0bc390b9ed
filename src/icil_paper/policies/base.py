"""The interface every policy implements (LeRobot-like), and what they share.

    policy = make_policy(ICRTConfig(), obs_spec, action_dim=7, tokenizer=LipVQConfig())
    policy.prepare(train_demos)                 # normalization stats, tokenizer.fit, pre-training
    batch = policy.sample_batch(data, batch_size, rng)
    loss, info = policy(batch)                  # training: a scalar loss and a dict of floats
    policy.reset(prompt=demos)                  # start an episode (ICRT: fill the KV cache)
    action = policy.select_action(obs)          # np.ndarray (A,) for one env observation
    policy.reset_batch([demos_0, demos_1, demos_2])         # B episodes at once
    actions = policy.select_actions([obs_0, obs_1, obs_2])  # (B, A): one batched forward
    actions = policy.select_actions([obs_0, obs_2], rows=[0, 2])  # episode 1 has finished

`reset_batch` / `select_actions` run B episodes in lockstep: one batched forward pass per
step (`BatchedPolicy`), or by default one copy of the policy per episode.

A policy is built from its config, its tokenizer's config and the data's shapes;
`policy.spec` holds them as JSON-ready data, from which `factory.build_policy` rebuilds it.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import torch
from torch import Tensor, nn

from icil_paper.config_data import to_dict
from icil_paper.policies.backbones import ObservationEncoder
from icil_paper.policies.batching import DemoSet, ObsSpec, as_obs_spec, check_demo, obs_batch
from icil_paper.policies.configs import PolicyConfig
from icil_paper.tokenizers import make_tokenizer
from icil_paper.tokenizers.configs import TokenizerConfig

TOKENIZER_SEED_OFFSET = 0x5EED
"""Added to torch's seed for the stream a policy's tokenizer is built from (`make_tokenizer`)."""


class Policy(nn.Module):
    """Base class of ICRT and the baselines.

    Subclasses set `name` and `uses_prompt` (when `reset` takes prompt demonstrations), and
    implement `sample_batch`, `forward`, `reset` and `select_action`.
    """

    name: str = "policy"
    uses_prompt: bool = False

    def __init__(self, config: PolicyConfig, obs_dim: int | Mapping[str, Any] | ObsSpec,
                 action_dim: int, tokenizer: TokenizerConfig | None = None):
        super().__init__()
        self.obs_spec = as_obs_spec(obs_dim)
        if action_dim < 1:
            raise ValueError(f"action_dim must be positive, got {action_dim}")
        if config.needs_images and self.obs_spec.image is None:
            raise ValueError(f"the {self.name} policy needs image observations (obs='rgb' or "
                             f"'rgbd'); got state observations {list(self.obs_spec.keys)}")
        self.action_dim = int(action_dim)
        self.config = config
        self.tokenizer_config = tokenizer
        # what rebuilds the policy (`factory.build_policy`), as JSON-ready data
        self.spec = {"policy": to_dict(config),
                     "tokenizer": to_dict(tokenizer) if tokenizer else None,
                     "obs_spec": to_dict(self.obs_spec), "action_dim": self.action_dim}
        self.instruction = ""

    # ---------------------------------------------------------------- shared parts
    def make_obs_encoder(self, spec: ObsSpec | None = None, separate: bool = False,
                         language: bool | None = None) -> ObservationEncoder:
        c = self.config
        return ObservationEncoder(spec or self.obs_spec, c.d_model, hidden=2 * c.d_model,
                                  resnet_width=c.resnet_width,
                                  language=c.language if language is None else language,
                                  separate=separate)

    def make_tokenizer(self) -> nn.Module | None:
        """The action tokenizer `tokenizer_config` describes (None without one), built from a
        random stream of its own, so that under one seed every tokenizer gets the same
        backbone (common random numbers)."""
        if self.tokenizer_config is None:
            return None

        with torch.random.fork_rng(devices=[]):
            torch.manual_seed((torch.initial_seed() + TOKENIZER_SEED_OFFSET) % 2**63)
            return make_tokenizer(self.tokenizer_config, self.action_dim)

    def no_weight_decay(self) -> list[nn.Parameter]:
        """Parameters the optimiser must not decay (the tokenizer's, if it names any)."""
        tok = getattr(self, "tokenizer", None)
        return tok.no_weight_decay() if tok is not None else []

    @property
    def device(self) -> torch.device:
        """Where the policy's parameters are (cpu for a policy without any)."""
        first = next(self.parameters(), None)
        return first.device if first is not None else torch.device("cpu")

    # ---------------------------------------------------------------- training
    def prepare(self, demos: DemoSet | Sequence[Any], pretrain: bool = True,
                progress: bool = False) -> DemoSet:
        """Fit normalization statistics and the tokenizer (if it needs fitting) to the
        training data; `pretrain=False` skips pre-training (MCR). Returns a DemoSet."""
        data = demos if isinstance(demos, DemoSet) else DemoSet(demos, self.obs_spec)
        if data.action_dim != self.action_dim:
            raise ValueError(f"demonstrations have action dimension {data.action_dim}, the "
                             f"policy expects {self.action_dim}")
        encoders = [m for m in self.modules() if isinstance(m, ObservationEncoder)]
        all_obs = data.all_obs()
        for enc in encoders:
            enc.set_stats(all_obs)
        tok = getattr(self, "tokenizer", None)
        if tok is not None and getattr(tok, "needs_fit", False):
            tok.fit(data.actions)
        return data

    def sample_batch(self, data: DemoSet, batch_size: int, rng: np.random.Generator) -> dict[str, Any]:
        raise NotImplementedError

    def forward(self, batch: Mapping[str, Any]) -> tuple[Tensor, dict[str, float]]:
        raise NotImplementedError

    # ---------------------------------------------------------------- acting
    def reset(self, prompt: Any = None, instruction: str | None = None) -> None:
        """Start an episode. `prompt`: demonstrations for in-context policies (ignored by the
        others); `instruction`: the task's language instruction (used if `language`)."""
        self.instruction = instruction or ""

    @torch.no_grad()
    def select_action(self, obs: Mapping[str, np.ndarray]) -> np.ndarray:
        raise NotImplementedError

    def obs_tensors_batch(self, obs: Sequence[Mapping[str, np.ndarray]]) -> dict[str, Tensor]:
        """B env observations -> {key: (B, 1, ...)} on the policy's device."""
        each = [obs_batch(o, self.obs_spec) for o in obs]  # B x {key: (1, 1, ...)}
        return {k: torch.cat([e[k] for e in each]).to(self.device) for k in self.obs_spec.keys}

    # ---------------------------------------------------------------- acting, batched
    def reset_batch(self, prompts: Sequence[Any], instructions: Sequence[str | None] | None = None
                    ) -> None:
        """Start B = len(prompts) episodes at once (prompts[b], instructions[b] as `reset`
        takes them); this default keeps one copy of the policy per episode."""
        instructions = batch_instructions(prompts, instructions)
        replicas = [self] if len(prompts) == 1 else [self._replica() for _ in prompts]
        for policy, prompt, text in zip(replicas, prompts, instructions, strict=True):
            policy.reset(prompt=prompt, instruction=text)
        self._replicas = replicas

    def select_actions(self, obs: Sequence[Mapping[str, np.ndarray]],
                       rows: Sequence[int] | None = None) -> np.ndarray:
        """One step of the episodes of `reset_batch`: obs[i] is episode rows[i]'s observation
        (default: all, in order; a finished episode is left out). Returns (len(obs), A)."""
        replicas = getattr(self, "_replicas", None)
        if replicas is None:
            raise RuntimeError("call reset_batch(prompts) before select_actions")
        rows = list(range(len(replicas))) if rows is None else list(rows)
        if len(rows) != len(obs):
            raise ValueError(f"{len(obs)} observations for {len(rows)} rows")
        return np.stack([np.asarray(replicas[r].select_action(o), np.float32)
                         for r, o in zip(rows, obs, strict=True)])

    def _replica(self) -> Policy:
        saved = self.__dict__.pop("_replicas", None)
        try:
            return copy.deepcopy(self)
        finally:
            if saved is not None:
                self._replicas = saved

    def n_params(self) -> int:
        return sum(p.numel() for p in self.parameters())


class BatchedPolicy(Policy):
    """A policy that acts for B episodes in one forward pass (ICRT and the baselines).

    Subclasses implement `select_actions` (calling `keep_rows` first) and extend `reset_batch`;
    `reset` and `select_action` are the batch of one.
    """

    def reset(self, prompt: Any = None, instruction: str | None = None) -> None:
        self.reset_batch([prompt], [instruction])

    def reset_batch(self, prompts: Sequence[Any], instructions: Sequence[str | None] | None = None
                    ) -> None:
        """Start B = len(prompts) episodes (prompts ignored: the baselines take none)."""
        self.begin_episodes([t or "" for t in batch_instructions(prompts, instructions)])

    @torch.no_grad()
    def select_action(self, obs: Mapping[str, np.ndarray]) -> np.ndarray:
        return self.select_actions([obs])[0]

    def begin_episodes(self, texts: Sequence[str]) -> None:
        """Start len(texts) episodes with these instructions (the rows 0 .. B - 1)."""
        self.instruction = texts[0]
        self._instructions = list(texts)
        self._rows = list(range(len(texts)))

    def keep_rows(self, rows: Sequence[int] | None, n_obs: int) -> Tensor | None:
        """Check `rows` against the running episodes; when some have finished, drop their
        instructions and return the positions of the remaining ones in the batched state
        (else None)."""
        current = getattr(self, "_rows", None)
        if current is None:
            raise RuntimeError("call reset(prompt=...) or reset_batch(...) before select_action")
        rows = list(current) if rows is None else [int(r) for r in rows]
        if len(rows) != n_obs:
            raise ValueError(f"{n_obs} observations for {len(rows)} rows")
        if rows == current:
            return None
        where = {r: i for i, r in enumerate(current)}
        if any(r not in where for r in rows) or rows != sorted(rows):
            raise ValueError(f"rows {rows} must be increasing and among the running episodes "
                             f"{current} (a finished episode cannot come back)")
        self._rows = rows
        keep = torch.tensor([where[r] for r in rows], dtype=torch.long, device=self.device)
        self._instructions = [self._instructions[i] for i in keep.tolist()]
        return keep


def batch_instructions(prompts: Sequence[Any], instructions: Sequence[str | None] | None
                        ) -> list[str | None]:
    """`reset_batch`'s instructions, one per prompt (None: each policy's default)."""
    if len(prompts) < 1:
        raise ValueError("reset_batch needs at least one episode (one prompt entry per episode)")
    if instructions is None:
        return [None] * len(prompts)
    instructions = list(instructions)
    if len(instructions) != len(prompts):
        raise ValueError(f"{len(prompts)} prompts but {len(instructions)} instructions")
    return instructions


def masked_l1(pred: Tensor, target: Tensor, valid: Tensor) -> Tensor:
    """Mean absolute error over valid entries; pred/target (..., A), valid (...) bool."""
    w = valid.to(pred.dtype)[..., None]
    denom = (w.sum() * pred.shape[-1]).clamp(min=1.0)
    return ((pred - target).abs() * w).sum() / denom


class TemporalEnsemble:
    """ACT's temporal ensembling: the action for step t averages every earlier chunk's
    prediction for t, with weights exp(-m i), i = 0 the oldest."""

    def __init__(self, chunk_size: int, m: float = 0.01):
        self.chunk_size, self.m = chunk_size, m
        self.reset()

    def reset(self) -> None:
        self.t = 0
        self.chunks: list[tuple[int, np.ndarray]] = []  # (step predicted at, (K, A))

    def __call__(self, chunk: np.ndarray) -> np.ndarray:
        self.chunks.append((self.t, chunk))
        self.chunks = [(s, c) for s, c in self.chunks if self.t - s < self.chunk_size]
        preds = np.stack([c[self.t - s] for s, c in self.chunks])  # oldest first
        w = np.exp(-self.m * np.arange(len(preds)))
        self.t += 1
        return (w[:, None] * preds).sum(0) / w.sum()


def validate_prompt(prompt: Any, spec: ObsSpec, action_dim: int) -> list[Any]:
    """Prompt demonstrations (a Demo-like object with `actions` (T, A) and `obs`, or a list of
    them) checked, as a list; ValueError naming the problem."""
    if prompt is None:
        raise ValueError("this policy needs a prompt: reset(prompt=...) with one or more "
                         "demonstrations of the task")
    demos = list(prompt) if isinstance(prompt, (list, tuple)) else [prompt]
    if not demos:
        raise ValueError("empty prompt: give at least one demonstration")
    for i, d in enumerate(demos):
        if not hasattr(d, "actions") or not hasattr(d, "obs"):
            raise ValueError(f"prompt item {i} is a {type(d).__name__}, not a demonstration "
                             "with `actions` and `obs`")
        check_demo(i, d, spec.keys, action_dim, what="prompt demonstration")
        for k in spec.keys:
            values = np.asarray(d.obs[k])
            if values.dtype.kind == "f" and not np.isfinite(values).all():
                raise ValueError(f"prompt demonstration {i}: obs[{k!r}] contains NaN or inf")
    return demos
