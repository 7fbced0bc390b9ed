"""Feature measurement: the latent features a trained policy's own tokenizer gives held-out
trajectories (Table III, Fig. 4), and whether Eq. 4 binds in its encoder.

    from icil_paper.eval import measure_features
    metrics = measure_features(policy, FeatureSpec(data=..., start=10, steps=500), "small")
    metrics["least_energy_standardized"], metrics["capped_fraction"]

Stored as a `features` record (`icil_paper.records.features_record`) by the table
scheduler (`icil_paper.tables.execute.run_cell`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from icil_paper.runspec import FeatureSpec


def measure_features(policy: Any, spec: FeatureSpec, preset: str) -> dict[str, Any]:
    """Table III's measurement: the latent features a trained policy's own tokenizer gives
    held-out trajectories (`spec.steps` features in all, in task order).

    Returns per-trajectory raw and standardized least energy (lists, for intervals), their
    means, the latent scale sigma, the codes used (discrete tokenizers), and the first
    `spec.view_steps` latents of the first trajectory (Fig. 4).
    """
    import torch

    from icil_paper.data import ensure_demos, load_demos
    from icil_paper.metrics import least_energy, standardized_least_energies

    d = spec.data
    pieces, left = [], spec.steps
    for task in d.tasks:
        path = ensure_demos(preset, task, d.source, n=spec.start + d.demos_per_task,
                            seed=d.seed, obs=d.obs, progress=False)
        for demo in load_demos(path, limit=spec.start + d.demos_per_task, images=False)[spec.start:]:
            if left < 3:
                break
            piece = np.asarray(demo.actions[:left], np.float32)
            pieces.append(piece)
            left -= len(piece)
    if not pieces:
        raise ValueError(f"no held-out trajectories for {list(d.tasks)} (demos {spec.start}..)")
    tokenizer = policy.tokenizer
    tokenizer.eval()
    latents, codes = [], []
    with torch.no_grad():
        for piece in pieces:
            out = tokenizer(torch.from_numpy(piece)[None].to(policy.device))
            latents.append(out.embeddings[0].float().cpu().numpy())
            if out.codes is not None:
                codes.append(tokenizer.vocabulary_ids(out.codes).cpu().numpy())
    standardized, sigma = standardized_least_energies(latents)
    raw = [least_energy(z) for z in latents]
    metrics = {"least_energy": float(np.mean(raw)), "least_energy_per_trajectory": raw,
               "least_energy_standardized": float(np.mean(standardized)),
               "least_energy_standardized_per_trajectory": [float(x) for x in standardized],
               "latent_scale": float(sigma), "n_features": int(sum(len(z) for z in latents)),
               "n_trajectories": len(latents),
               "view": latents[0][:spec.view_steps].tolist(),
               "view_actions": pieces[0][:spec.view_steps].tolist()}
    if codes:
        used = np.unique(np.concatenate(codes))
        metrics.update(codes_used=int(len(used)), codebook_size=int(tokenizer.codebook_size))
    metrics.update(lipschitz_diagnostics(tokenizer, np.concatenate(pieces)))
    return metrics


def lipschitz_diagnostics(tokenizer: Any, actions: np.ndarray) -> dict[str, Any]:
    """Does Eq. 4 bind in a trained encoder? For tokenizers with Lipschitz layers: the share
    of rows whose absolute sum the bound caps (`capped_fraction`, all layers together), each
    layer's bound softplus(c_l), their product (the network's bound, Eq. 3), and, for every
    tokenizer with an encoder, the largest ratio ||q(x) - q(x')||_inf / ||x - x'||_inf over
    random nearby pairs of held-out actions (`empirical_lipschitz`, a lower estimate)."""
    import math

    import torch
    import torch.nn.functional as F

    from icil_paper.metrics import empirical_lipschitz
    from icil_paper.tokenizers.lipschitz_linear import lipschitz_layers

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
