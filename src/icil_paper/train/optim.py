"""Optimisation: AdamW with decoupled decay on matrices and the Lipschitz bounds' own learning
rate, warm-up + cosine, EMA (torch's CPU threads: `icil_paper.seeding.cpu_threads`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import torch
from torch import nn

from icil_paper.tokenizers.lipschitz_linear import bound_parameter_groups


def cosine_schedule(warmup: int, total: int):
    """lr multiplier: linear warm-up over `warmup` steps, then half-cycle cosine to 0."""
    def factor(step: int) -> float:
        if step < warmup:
            return (step + 1) / max(1, warmup)
        progress = (step - warmup) / max(1, total - warmup)
        return 0.5 * (1.0 + math.cos(math.pi * min(1.0, progress)))
    return factor


def make_optimizer(model: nn.Module, lr: float, weight_decay: float,
                   betas: tuple[float, float]) -> torch.optim.AdamW:
    """AdamW with weight decay on matrices only (none on the model's `no_weight_decay()`);
    the Lipschitz bounds c (Eq. 4) get their own groups (`bound_parameter_groups`)."""
    bounds = bound_parameter_groups(model, lr)
    own_group = {id(p) for group in bounds for p in group["params"]}
    exempt = {id(p) for p in getattr(model, "no_weight_decay", list)()}
    params = [p for p in model.parameters() if p.requires_grad and id(p) not in own_group]
    decay = [p for p in params if p.ndim >= 2 and id(p) not in exempt]
    no_decay = [p for p in params if p.ndim < 2 or id(p) in exempt]
    return torch.optim.AdamW([{"params": decay, "weight_decay": weight_decay},
                              {"params": no_decay, "weight_decay": 0.0}, *bounds],
                             lr=lr, betas=tuple(betas))


class EMA:
    """Exponential moving average of a model's floating-point parameters and buffers.

    decay_t = min(decay, (1 + t) / (10 + t)): averaging starts short and grows to `decay`.
    """

    def __init__(self, model: nn.Module, decay: float):
        self.decay = decay
        self.step = 0
        self.shadow = {k: v.detach().clone() for k, v in model.state_dict().items()
                       if isinstance(v, torch.Tensor) and v.is_floating_point()}

    @torch.no_grad()
    def update(self, model: nn.Module) -> None:
        d = min(self.decay, (1 + self.step) / (10 + self.step))
        for k, v in model.state_dict().items():
            if k in self.shadow:
                self.shadow[k].mul_(d).add_(v.detach(), alpha=1 - d)
        self.step += 1

    def copy_to(self, model: nn.Module) -> None:
        model.load_state_dict({**model.state_dict(), **self.shadow})

    def state_dict(self) -> dict[str, Any]:
        return {"decay": self.decay, "step": self.step, "shadow": self.shadow}

    def load_state_dict(self, state: Mapping[str, Any]) -> None:
        self.decay, self.step = state["decay"], state["step"]
        self.shadow = {k: v.clone() for k, v in state["shadow"].items()}
