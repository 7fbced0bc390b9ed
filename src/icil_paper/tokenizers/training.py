"""Stand-alone tokenizer training and the measurements chapter 05 and the benchmark report.

    tok = make_tokenizer(stand_alone(preset.tokenizers.lipvq), action_dim=7)
    result = train_tokenizer(tok, trajectories, preset.tokenizer_study, seed=0)
    metrics = evaluate_tokenizer(tok, held_out_trajectories)

Batches are random windows of `config.window` steps from random trajectories:

    trajectory i:  a_0 a_1 ... a_s [a_s ... a_{s+W-1}] ... a_{T_i - 1}
                                   `------ window ------'   s uniform in [0, T_i - W]
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence

import numpy as np
import torch
from tqdm.auto import tqdm

from icil_paper.metrics import (
    codebook_usage,
    least_energy,
    smoothness_summary,
    standardized_least_energies,
)
from icil_paper.seeding import cpu_threads
from icil_paper.tokenizers.base import ActionTokenizer, as_trajectory_list, evaluating
from icil_paper.tokenizers.configs import TokenizerConfig, TokenizerStudyConfig
from icil_paper.tokenizers.lipschitz_linear import bound_parameter_groups, lipschitz_bounds


def stand_alone(config: TokenizerConfig) -> TokenizerConfig:
    """The config with `autoencode` on where it has that field (mlp, lip-mlp, bin, fast,
    bspline): trained alone, their embeddings must learn from reconstruction."""
    if "autoencode" in {f.name for f in dataclasses.fields(config)}:
        return dataclasses.replace(config, autoencode=True)
    return config


def sample_windows(trajectories: Sequence[np.ndarray], batch_size: int, window: int,
                   rng: np.random.Generator) -> np.ndarray:
    """Random windows (batch_size, window, A); short trajectories repeat their last action."""
    out = np.empty((batch_size, window, trajectories[0].shape[1]), dtype=np.float32)
    for b, i in enumerate(rng.integers(len(trajectories), size=batch_size)):
        traj = trajectories[i]
        start = int(rng.integers(max(len(traj) - window, 0) + 1))
        out[b] = traj[np.minimum(np.arange(start, start + window), len(traj) - 1)]
    return out


def train_tokenizer(tokenizer: ActionTokenizer, trajectories, config: TokenizerStudyConfig,
                    seed: int = 0, progress: bool = True, steps: int | None = None,
                    log_every: int | None = None, threads: int | None = 1) -> dict:
    """Train `tokenizer` (fitted first if needed) on its own for `config.steps` Adam steps.

    Returns `{"steps", "wall_time_s", "history"}`; every `log_every` steps the history logs
    the step, the total loss, each weighted loss term and the Lipschitz bounds softplus(c_l).
    threads: torch threads while training (one is fastest for these tiny models).
    """
    with cpu_threads(threads):
        trajectories = [t.astype(np.float32) for t in
                        as_trajectory_list(trajectories, tokenizer.action_dim)]
        if not tokenizer.fitted:
            tokenizer.fit(trajectories)
        steps = config.steps if steps is None else steps
        log_every = log_every or max(1, steps // 50)
        rng = np.random.default_rng(seed)
        bounds = bound_parameter_groups(tokenizer, config.lr)  # Eq. 4's c at its own lr
        own_group = {id(p) for group in bounds for p in group["params"]}
        params = [p for p in tokenizer.parameters() if p.requires_grad and id(p) not in own_group]
        optimizer = torch.optim.Adam([{"params": params}, *bounds], lr=config.lr)
        history: dict[str, list] = {"step": [], "loss": [], "lipschitz_bounds": []}
        tokenizer.train()
        start = time.perf_counter()
        bar = tqdm(range(1, steps + 1), desc=f"train {tokenizer.name}", disable=not progress,
                   leave=False)
        for step in bar:
            batch = sample_windows(trajectories, config.batch_size, config.window, rng)
            out = tokenizer(torch.from_numpy(batch))
            loss = out.total_loss()
            optimizer.zero_grad(set_to_none=True)
            loss.backward()
            optimizer.step()
            if step % log_every == 0 or step == 1 or step == steps:
                history["step"].append(step)
                history["loss"].append(loss.item())
                for key, value in out.losses.items():
                    history.setdefault(key, []).append(value.item())
                history["lipschitz_bounds"].append(lipschitz_bounds(tokenizer))
                bar.set_postfix(loss=f"{loss.item():.4f}")
        tokenizer.eval()
        return {"steps": steps, "wall_time_s": time.perf_counter() - start, "history": history}


# ---------------------------------------------------------------------- evaluation
def _each(tokenizer: ActionTokenizer, trajectories):
    """(trajectory tensor (1, T, A), output) per trajectory, in eval mode without gradients."""
    with evaluating(tokenizer):
        for traj in as_trajectory_list(trajectories, tokenizer.action_dim):
            x = torch.as_tensor(traj, dtype=torch.float32)[None]
            yield x, tokenizer(x)


def reconstruction_errors(tokenizer: ActionTokenizer, trajectories) -> dict[str, float]:
    """Mean squared errors over `trajectories` of the tokenizer's own reconstruction
    (`reconstruction_mse`) and of `decode(embeddings)` (`decode_mse`)."""
    sq_rec = sq_dec = n = 0.0
    for x, out in _each(tokenizer, trajectories):
        sq_rec += float(((out.reconstruction - x) ** 2).sum())
        sq_dec += float(((tokenizer.decode(out.embeddings) - x) ** 2).sum())
        n += x.numel()
    return {"reconstruction_mse": sq_rec / n, "decode_mse": sq_dec / n}


def codebook_stats(tokenizer: ActionTokenizer, trajectories) -> dict[str, float | None]:
    """Codebook usage and perplexity over `trajectories` (None for continuous tokenizers),
    and the distinct codes of each level for residual VQ (`codes_used_per_level`)."""
    if not tokenizer.discrete:
        return {"codebook_size": None, "usage": None, "perplexity": None, "codes_used": None,
                "codes_used_per_level": None}
    codes = [out.codes for _, out in _each(tokenizer, trajectories)]
    ids = torch.cat([tokenizer.vocabulary_ids(c) for c in codes])
    levels = [tokenizer.codes_by_level(c) for c in codes]
    per_level = None if levels[0] is None else [
        int(torch.cat(level).unique().numel()) for level in zip(*levels, strict=True)]
    return {"codebook_size": tokenizer.codebook_size,
            **codebook_usage(ids, tokenizer.codebook_size), "codes_used_per_level": per_level}


def smoothness(tokenizer: ActionTokenizer, trajectories) -> dict:
    """Smoothness of the embedding sequences (T, D) of `trajectories`: the mean raw and
    standardized least energy, the latent scale sigma (`metrics.smoothness_summary`), and
    both scores per trajectory (`..._per_trajectory`, for intervals)."""
    latents = [out.embeddings[0] for _, out in _each(tokenizer, trajectories)]
    standardized, _ = standardized_least_energies(latents)
    return {**smoothness_summary(latents),
            "least_energy_per_trajectory": [least_energy(z) for z in latents],
            "least_energy_standardized_per_trajectory": [float(x) for x in standardized]}


def throughput(tokenizer: ActionTokenizer, actions: torch.Tensor, min_time: float = 0.5,
               max_repeats: int = 1000, threads: int | None = 1) -> dict[str, float]:
    """Actions per second for encode (`forward`), `decode`, and both, on a batch (B, T, A),
    each timed over repeats for `min_time` seconds after a warm-up, on `threads` threads."""
    n_actions = actions.shape[0] * actions.shape[1]

    def rate(fn) -> float:
        start, repeats = time.perf_counter(), 0
        while repeats < max_repeats:
            fn()
            repeats += 1
            if time.perf_counter() - start >= min_time:
                break
        return repeats * n_actions / (time.perf_counter() - start)

    with evaluating(tokenizer):
        emb = tokenizer(actions).embeddings
        tokenizer.decode(emb)
        with cpu_threads(threads):
            encode = rate(lambda: tokenizer(actions))
            decode = rate(lambda: tokenizer.decode(emb))
            both = rate(lambda: tokenizer.decode(tokenizer(actions).embeddings))
    return {"encode_actions_per_s": encode, "decode_actions_per_s": decode,
            "encode_decode_actions_per_s": both}


def evaluate_tokenizer(tokenizer: ActionTokenizer, trajectories,
                       throughput_batch: tuple[int, int] = (32, 16), seed: int = 0,
                       min_time: float = 0.5, threads: int | None = 1,
                       timing: bool = True) -> dict[str, float | None]:
    """Every measurement of chapter 05 on held-out `trajectories`, as one flat dict:
    reconstruction errors, codebook usage, tokens per step, throughput on `throughput_batch`
    (B, T) windows (None with `timing=False`) and the smoothness scores."""
    trajectories = [t.astype(np.float32) for t in
                    as_trajectory_list(trajectories, tokenizer.action_dim)]
    metrics: dict[str, float | None] = {}
    with cpu_threads(threads):
        metrics.update(reconstruction_errors(tokenizer, trajectories))
        metrics.update(codebook_stats(tokenizer, trajectories))
        metrics["tokens_per_step"] = tokenizer.tokens_per_step(trajectories)
        if timing:
            batch = sample_windows(trajectories, *throughput_batch, np.random.default_rng(seed))
            metrics.update(throughput(tokenizer, torch.from_numpy(batch), min_time=min_time,
                                      threads=None))
        else:
            metrics.update(dict.fromkeys(("encode_actions_per_s", "decode_actions_per_s",
                                          "encode_decode_actions_per_s")))
        metrics.update(smoothness(tokenizer, trajectories))
    return metrics
