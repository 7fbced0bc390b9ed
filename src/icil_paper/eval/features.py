"""Feature measurement: the latent features a trained policy's own tokenizer gives held-out
trajectories (Table III, Fig. 4), its codebook use, and whether Eq. 4 binds in its encoder.

    from icil_paper.eval import measure_features
    metrics = measure_features(policy, FeatureSpec(data=..., start=10, steps=500), "small")
    metrics["least_energy_standardized"], metrics["capped_fraction"], metrics["perplexity"]

With `sampling="per_task"` every task gets `spec.steps // len(tasks)` steps, taken from its
held-out trajectories in order, each cut to what is left of the task's share:

    task 1: |--- trajectory 1 ---|-- 2 --|        share steps
    task 2: |-------- trajectory 1 ------|        share steps
    task 3: |-- trajectory 1 --|                  all it has (shorter than its share)

`task_order` scores the first `steps` of the trajectories in task order instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from icil_paper.data import ensure_demos, load_demos
from icil_paper.metrics import (
    codebook_usage,
    empirical_lipschitz,
    least_energy,
    standardized_least_energies,
)
from icil_paper.runspec import FeatureSpec
from icil_paper.tokenizers.lipschitz_linear import lipschitz_layers

MIN_PIECE = 3
"""Fewest steps of a scored piece (a least energy needs three points)."""


@dataclass(frozen=True)
class HeldOutPiece:
    """One scored stretch of a held-out trajectory."""

    task: str
    demo: int
    """Index of the demonstration in that data set."""
    actions: np.ndarray
    """Its first steps' actions (T, A), T at most the task's share."""


def held_out_pieces(spec: FeatureSpec, preset: Any) -> list[HeldOutPiece]:
    """The held-out pieces `spec` scores, cut per `spec.sampling` (module docstring)."""
    d = spec.data
    n = spec.start + d.demos_per_task
    per_task = spec.sampling == "per_task"
    share = spec.steps // len(d.tasks)
    pieces: list[HeldOutPiece] = []
    left = spec.steps
    for task in d.tasks:
        if per_task:
            left = share
        path = ensure_demos(preset, task, d.source, n=n, seed=d.seed, obs=d.obs, progress=False)
        for index, demo in enumerate(load_demos(path, limit=n, images=False)[spec.start:],
                                     start=spec.start):
            if left < MIN_PIECE:
                break
            actions = np.asarray(demo.actions[:left], np.float32)  # (T, A)
            if len(actions) < MIN_PIECE:
                continue
            pieces.append(HeldOutPiece(task, index, actions))
            left -= len(actions)
    if not pieces:
        raise ValueError(f"no held-out trajectories for {list(d.tasks)} (demos {spec.start}..)")
    return pieces


def coverage(spec: FeatureSpec, pieces: list[HeldOutPiece]) -> dict[str, Any]:
    """What `pieces` score, for the record: tasks scored, steps and trajectories per task."""
    steps = {t: 0 for t in spec.data.tasks}
    trajectories = {t: 0 for t in spec.data.tasks}
    for p in pieces:
        steps[p.task] += len(p.actions)
        trajectories[p.task] += 1
    return {"sampling": spec.sampling, "tasks": list(spec.data.tasks),
            "tasks_scored": [t for t in spec.data.tasks if steps[t]],
            "steps_per_task": steps, "trajectories_per_task": trajectories}


def measure_features(policy: Any, spec: FeatureSpec, preset: Any) -> dict[str, Any]:
    """Table III's measurement on the latents a policy's tokenizer gives the held-out pieces:
    raw and standardized least energy, `coverage`, codebook use (discrete tokenizers),
    `lipschitz_diagnostics` and the first `spec.view_steps` latents (Fig. 4)."""
    import torch

    pieces = held_out_pieces(spec, preset)
    actions = [p.actions for p in pieces]
    tokenizer = policy.tokenizer
    tokenizer.eval()
    latents, codes = [], []
    with torch.no_grad():
        for piece in actions:
            out = tokenizer(torch.from_numpy(piece)[None].to(policy.device))
            latents.append(out.embeddings[0].float().cpu().numpy())  # (T, D)
            if out.codes is not None:
                codes.append(tokenizer.vocabulary_ids(out.codes).cpu().numpy())
    standardized, sigma = standardized_least_energies(latents)
    raw = [least_energy(z) for z in latents]
    metrics = {"least_energy": float(np.mean(raw)), "least_energy_per_trajectory": raw,
               "least_energy_standardized": float(np.mean(standardized)),
               "least_energy_standardized_per_trajectory": [float(x) for x in standardized],
               "latent_scale": float(sigma), "n_features": int(sum(len(z) for z in latents)),
               "n_trajectories": len(latents), **coverage(spec, pieces),
               "view": latents[0][:spec.view_steps].tolist(),
               "view_actions": actions[0][:spec.view_steps].tolist()}
    if codes:
        size = int(tokenizer.codebook_size)
        usage = codebook_usage(np.concatenate(codes), size)
        metrics.update(codes_used=usage["codes_used"], codebook_size=size,
                       usage=usage["usage"], perplexity=usage["perplexity"])
    metrics.update(lipschitz_diagnostics(tokenizer, np.concatenate(actions)))
    return metrics


def lipschitz_diagnostics(tokenizer: Any, actions: np.ndarray) -> dict[str, Any]:
    """Does Eq. 4 bind? `capped_fraction` of rows the bound caps, each layer's softplus(c_l)
    and their product (Eq. 3), and an `empirical_lipschitz` lower estimate of the encoder."""
    import torch
    import torch.nn.functional as F

    out: dict[str, Any] = {"capped_fraction": None, "layer_bounds": None, "bound_product": None,
                           "empirical_lipschitz": None}
    layers = lipschitz_layers(tokenizer)
    if layers:
        with torch.no_grad():
            capped = rows = 0
            for layer in layers:
                sums = layer.weight.abs().sum(dim=1)
                capped += int((sums > F.softplus(layer.c)).sum())
                rows += len(sums)
            bounds = [float(layer.lipschitz_bound()) for layer in layers]
        out.update(capped_fraction=capped / rows, layer_bounds=bounds,
                   bound_product=float(np.prod(bounds)))
    encoder = getattr(tokenizer, "encoder", None)
    if encoder is not None:
        anchors = torch.from_numpy(np.asarray(actions, np.float32))
        out["empirical_lipschitz"] = empirical_lipschitz(encoder, anchors, n_pairs=2000,
                                                         radius=0.05, seed=0, ord=math.inf)
    return out
