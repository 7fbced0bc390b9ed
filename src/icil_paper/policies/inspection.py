"""Look inside a trained ICRT on one batch: what each token is, and where the loss reaches.

    from icil_paper.policies.inspection import token_roles, token_loss_gradients
    roles = token_roles(policy, batch)           # segment, kind, step, valid, supervised
    grads = token_loss_gradients(policy, batch)  # (B, L) |dL/dh| at each output position

`batch` is a training batch of `prompt_query_batch` (layout in `policies.batching`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import torch
from torch import Tensor

from icil_paper.policies.icrt import ICRT


def token_roles(policy: ICRT, batch: Mapping[str, Any]) -> dict[str, Tensor]:
    """What each position of a batch's token sequence is, all (B, L):

    segment (0 prompt, 1 query), kind (0 observation, 1 action), step (the demo step the
    token belongs to), valid (a real token, not padding), supervised (a query observation
    token with at least one target action: where the loss is computed).
    """
    pv, qv = batch["prompt_valid"], batch["query_valid"]
    B, M = pv.shape
    N = qv.shape[1]
    per_q = 2 if policy.query_actions else 1
    seg = torch.cat([torch.zeros(B, 2 * M), torch.ones(B, per_q * N)], 1).long()
    kind = torch.cat([torch.arange(2 * M) % 2, torch.arange(per_q * N) % per_q]).long()
    step = torch.cat([torch.arange(2 * M) // 2, torch.arange(per_q * N) // per_q]).long()
    valid = torch.cat([pv.repeat_interleave(2, 1), qv.repeat_interleave(per_q, 1)], 1)
    supervised = torch.zeros(B, 2 * M + per_q * N, dtype=torch.bool)
    supervised[:, 2 * M::per_q] = batch["target_valid"].any(-1) if "target_valid" in batch else qv
    return {"segment": seg, "kind": kind.expand(B, -1), "step": step.expand(B, -1),
            "valid": valid, "supervised": supervised}


def token_loss_gradients(policy: ICRT, batch: Mapping[str, Any]) -> Tensor:
    """|d loss / d h| at every position of the transformer's output, (B, L): zero wherever
    the loss does not reach directly. The policy's gradients are cleared afterwards."""
    captured: dict[str, Tensor] = {}

    def keep(_module, _inputs, output):
        output.retain_grad()
        captured["h"] = output

    handle = policy.transformer.register_forward_hook(keep)
    try:
        loss, _ = policy(batch)
        policy.zero_grad(set_to_none=True)
        loss.backward()
    finally:
        handle.remove()
    grad = captured["h"].grad.norm(dim=-1).detach()
    policy.zero_grad(set_to_none=True)
    return grad
