"""Experiments that a chapter and `icil-paper reproduce` share.

Each study takes a preset and a results store, runs what is missing through
`ResultsStore.run` (so a second call only loads) and returns the metrics by run label.
`reproduce` calls them to fill the store; the notebooks call them again to draw.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from icil_paper.config import Preset
from icil_paper.results import ResultsStore

VIEW_STEPS = 40
"""Steps of one held-out trajectory kept (as 2 principal components) for latent plots."""


def tokenizer_runs() -> list[tuple[str, str, dict]]:
    """(label, registry name, options): every tokenizer, plus the official code's LipVQ."""
    from icil_paper.tokenizers import TOKENIZERS

    return [(name, name, {}) for name in TOKENIZERS] + [
        ("lipvq-official", "lipvq", {"variant": "official"})]


def _train_alone(preset: Preset, name: str, options: dict):
    """Seed, generate train/test trajectories, train one tokenizer alone; return all three."""
    from icil_paper.seeding import seed_everything
    from icil_paper.tokenizers.training import build_tokenizer, train_tokenizer
    from icil_paper.trajectories import ACTION_DIM, generate_trajectories

    cfg = preset.tokenizer
    seed_everything(preset.seed)
    train = generate_trajectories(cfg.n_trajectories, seed=preset.seed, noise=cfg.trajectory_noise)
    test = generate_trajectories(cfg.n_eval_trajectories, seed=preset.seed + 1,
                                 noise=cfg.trajectory_noise)
    tok = build_tokenizer(name, ACTION_DIM, cfg, stand_alone=True, **options)
    result = train_tokenizer(tok, train, cfg, seed=preset.seed, progress=True)
    return tok, result, test


def _train_and_measure_tokenizer(preset: Preset, name: str, options: dict) -> dict:
    import torch

    from icil_paper.tokenizers.training import evaluate_tokenizer

    tok, result, test = _train_alone(preset, name, options)
    metrics = evaluate_tokenizer(tok, test, seed=preset.seed)
    metrics["train_s"] = result["wall_time_s"]
    metrics["final_loss"] = result["history"]["loss"][-1]
    # A 2-D view of one latent trajectory (principal components), for the chapter's figure.
    with torch.no_grad():
        z = tok.eval()(torch.from_numpy(test[0][None, :VIEW_STEPS])).embeddings[0].numpy()
    z = z - z.mean(0)
    _, _, vt = np.linalg.svd(z, full_matrices=False)
    metrics["latent_view"] = (z @ vt[:2].T).tolist()
    return metrics


def tokenizer_study(preset: Preset, store: ResultsStore | None = None,
                    force: bool = False) -> dict[str, dict]:
    """Chapter 04: train every tokenizer alone on action trajectories and measure it."""
    store = store or ResultsStore(preset.name)
    records = {}
    for label, name, options in tokenizer_runs():
        config = {"chapter": "04", "tokenizer": name, "options": options,
                  "tokenizer_config": dataclasses.asdict(preset.tokenizer),
                  "seed": preset.seed, "trajectories": "generated (icil_paper.trajectories)"}
        records[label] = store.run(
            "tokenizer", label, config,
            lambda name=name, options=options: _train_and_measure_tokenizer(preset, name, options),
            seed=preset.seed, force=force)["metrics"]
    return records


LIPSCHITZ_MODELS = (
    ("lipvq (paper)", "lipvq", {}),
    ("lipvq (official code)", "lipvq", {"variant": "official"}),
    ("vq + spectral norm", "vq", {"norm": "spectral"}),
    ("vq (no normalization)", "vq", {}),
)
"""Encoders compared in chapter 02: (label, tokenizer name, options)."""

LIPSCHITZ_RADII = (1e-3, 1e-2, 1e-1, 1.0)
"""Perturbation radii of the random pairs that estimate an empirical Lipschitz constant."""


def _lipschitz_measurements(preset: Preset, name: str, options: dict) -> dict:
    import math

    import torch

    from icil_paper.metrics import empirical_lipschitz
    from icil_paper.tokenizers import lipschitz_bounds, lipschitz_loss
    from icil_paper.tokenizers.lipschitz_linear import weight_norm_bound
    from icil_paper.tokenizers.training import reconstruction_errors, smoothness

    tok, result, test = _train_alone(preset, name, options)
    anchors = torch.from_numpy(np.concatenate(test))
    metrics = {
        "bound_inf": weight_norm_bound(tok.encoder, math.inf),
        "bound_2": weight_norm_bound(tok.encoder, 2),
        "bound_softplus_product": (lipschitz_loss(tok.encoder).item()
                                   if lipschitz_bounds(tok) else None),
        "c_history": result["history"]["lipschitz_bounds"],
        "history_step": result["history"]["step"],
        "train_s": result["wall_time_s"],
    }
    for radius in LIPSCHITZ_RADII:
        for ord_name, ord_value in (("inf", math.inf), ("2", 2)):
            metrics[f"empirical_{ord_name}_r{radius:g}"] = empirical_lipschitz(
                tok.encoder, anchors, n_pairs=4000, radius=radius, seed=preset.seed,
                ord=ord_value)
    metrics.update(reconstruction_errors(tok, test))
    metrics.update({f"latent_{k}": v for k, v in smoothness(tok, test).items()})
    return metrics


def lipschitz_study(preset: Preset, store: ResultsStore | None = None,
                    force: bool = False) -> dict[str, dict]:
    """Chapter 02: train encoders with and without normalization; bounds vs empirical constants."""
    store = store or ResultsStore(preset.name)
    records = {}
    for label, name, options in LIPSCHITZ_MODELS:
        config = {"chapter": "02", "tokenizer": name, "options": options,
                  "tokenizer_config": dataclasses.asdict(preset.tokenizer), "seed": preset.seed,
                  "trajectories": "generated (icil_paper.trajectories)",
                  "radii": list(LIPSCHITZ_RADII)}
        records[label] = store.run(
            "lipschitz", label, config,
            lambda name=name, options=options: _lipschitz_measurements(preset, name, options),
            seed=preset.seed, force=force)["metrics"]
    return records
