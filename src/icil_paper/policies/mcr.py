"""MCR (Jiang et al. 2025): a manipulation-centric visual encoder, frozen under a BC head.

No MCR checkpoint can be downloaded here, so `prepare` pre-trains the library's ResNet-18
on the training demonstrations with MCR's three objectives, then freezes it:

    image I_t ─ ResNet-18 ─ v_t ──┬─ dynamics alignment: InfoNCE(v_t, g(proprio_t, a_t..a_(t+K-1)))
                                  ├─ action prediction: L1(f(v_t), a_t..a_(t+K-1))
                                  └─ time contrastive: InfoNCE(v_t, v_(t+dt)), |dt| <= 3

    then:  frozen v_t ─┐
           state_t ────┴─ MLP head ─> â_t .. â_(t+K-1)     (L1; the first action is executed)

MCR needs images (`DataConfig.obs = "rgb"` or `"rgbd"`); depth enters the ResNet as a fourth
input channel.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor, nn
from tqdm.auto import tqdm

from icil_paper.layers import mlp
from icil_paper.policies.base import BatchedPolicy, masked_l1
from icil_paper.policies.batching import DemoSet, ObsSpec, _stack_obs, _take, window_batch
from icil_paper.policies.configs import MCRConfig, register_policy_model


def info_nce(a: Tensor, b: Tensor, temperature: float = 0.1) -> Tensor:
    """Symmetric InfoNCE between matching rows of a and b (B, D); other rows are negatives."""
    a, b = F.normalize(a, dim=-1), F.normalize(b, dim=-1)
    logits = a @ b.T / temperature  # (B, B)
    labels = torch.arange(len(a), device=a.device)
    return 0.5 * (F.cross_entropy(logits, labels) + F.cross_entropy(logits.T, labels))


@register_policy_model("mcr")
class MCR(BatchedPolicy):
    """Frozen manipulation-centric visual encoder + behaviour-cloning MLP head (MCRConfig)."""

    name = "mcr"

    def __init__(self, config: MCRConfig, obs_dim: int | Mapping[str, Any] | ObsSpec,
                 action_dim: int, tokenizer: None = None):
        super().__init__(config, obs_dim, action_dim, None)
        D, K, spec = config.d_model, config.chunk_size, self.obs_spec
        self.chunk_size = K
        self.visual = self.make_obs_encoder(ObsSpec((), 0, spec.image, spec.depth), language=False)
        self.state = None
        if spec.lowdim_dim:
            self.state = self.make_obs_encoder(ObsSpec(spec.lowdim_keys, spec.lowdim_dim))
        # pre-training heads (unused once the encoder is frozen)
        self.pre_dynamics = mlp([max(spec.lowdim_dim, 1) + K * action_dim, D, D], nn.GELU)
        self.pre_action = mlp([D, D, K * action_dim], nn.GELU)
        self.pre_proj = mlp([D, D, D], nn.GELU)
        self.head = mlp([D * (2 if self.state is not None else 1), D, K * action_dim], nn.GELU)
        self.register_buffer("pretrained", torch.tensor(False))

    # ------------------------------------------------------------------ pre-training
    def prepare(self, demos: DemoSet | Sequence[Any], pretrain: bool = True,
                progress: bool = False) -> DemoSet:
        data = super().prepare(demos)
        if pretrain and not bool(self.pretrained):
            self.pretrain(data, progress=progress)
        self.visual.requires_grad_(False)  # frozen under the BC head
        return data

    def pretrain(self, data: DemoSet, steps: int | None = None, progress: bool = False) -> list[float]:
        """Manipulation-centric pre-training of `visual`; returns the loss per step."""
        c = self.config
        steps = c.pretrain_steps if steps is None else steps
        B = c.pretrain_batch
        rng = np.random.default_rng(int(torch.randint(2**31 - 1, ()).item()))
        params = [p for m in (self.visual, self.pre_dynamics, self.pre_action, self.pre_proj)
                  for p in m.parameters()]
        opt = torch.optim.AdamW(params, lr=c.pretrain_lr)
        was_training = self.training
        self.train()
        losses = []
        for _ in tqdm(range(steps), desc="mcr pre-training", disable=not progress, leave=False):
            batch = window_batch(data, B, 1, self.chunk_size, rng)
            positive = self._nearby_frames(data, batch, rng)
            obs, chunk, valid = batch["obs"], batch["targets"].float(), batch["target_valid"]
            v = self.visual(obs)[:, -1]  # (B, D)
            v_pos = self.visual(positive)[:, -1]
            state = torch.zeros(B, 1) if self.state is None else self.state.lowdim(obs)[:, -1]
            dyn = self.pre_dynamics(torch.cat([state, chunk.flatten(1)], dim=-1))
            l_dyn = info_nce(self.pre_proj(v), dyn)
            l_act = masked_l1(self.pre_action(v).view_as(chunk), chunk, valid)
            l_tcn = info_nce(self.pre_proj(v), self.pre_proj(v_pos))
            loss = l_dyn + l_act + l_tcn
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            losses.append(float(loss.detach()))
        self.pretrained.fill_(True)
        self.train(was_training)
        return losses

    def _nearby_frames(self, data: DemoSet, batch: Mapping[str, Any], rng: np.random.Generator,
                       radius: int = 3) -> dict[str, Tensor]:
        demo, step = batch["index"]  # the (demonstration, step) of each sample
        rows = []
        for d, t in zip(demo.tolist(), step.tolist(), strict=True):
            dt = int(rng.integers(1, radius + 1)) * (1 if rng.random() < 0.5 else -1)
            idx = np.array([t + dt])
            rows.append({k: _take(v, idx) for k, v in data.obs[d].items()})
        return _stack_obs(rows)

    # ------------------------------------------------------------------ behaviour cloning
    def sample_batch(self, data: DemoSet, batch_size: int, rng: np.random.Generator) -> dict[str, Any]:
        return window_batch(data, batch_size, 1, self.chunk_size, rng)

    def predict(self, obs: Mapping[str, Tensor], instructions=None) -> Tensor:
        """obs {key: (B, 1, ...)} -> chunk (B, K, A)."""
        with torch.no_grad():
            v = self.visual(obs)[:, -1]  # (B, D), frozen
        feats = [v]
        if self.state is not None:
            feats.append(self.state(obs, instructions)[:, -1])
        B = v.shape[0]
        return self.head(torch.cat(feats, dim=-1)).view(B, self.chunk_size, self.action_dim)

    def forward(self, batch: Mapping[str, Any]) -> tuple[Tensor, dict[str, float]]:
        pred = self.predict(batch["obs"], batch.get("instruction"))
        loss = masked_l1(pred, batch["targets"].float(), batch["target_valid"])
        return loss, {"action_l1": float(loss.detach())}

    @torch.no_grad()
    def select_actions(self, obs: Sequence[Mapping[str, np.ndarray]],
                       rows: Sequence[int] | None = None) -> np.ndarray:
        """Each episode's first predicted action (len(obs), A), in one forward pass."""
        self.keep_rows(rows, len(obs))
        chunk = self.predict(self.obs_tensors_batch(obs), self._instructions)  # (B, K, A)
        return chunk[:, 0].float().cpu().numpy()
