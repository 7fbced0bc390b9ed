"""The chapters on the paper's method (Sec. III): ICRT (chapter 02) and Eq. 4 (chapter 03).

    display(attention_mask_figure(mask, batch, b))        # chapter 02
    coverage = loss_coverage(roles, grads)                 # tokens the loss reaches, by kind
    display(lipschitz_frame(records, radii))               # chapter 03: bounds and constants

Figures are closed before they are returned, so each shows once, where displayed.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from icil_paper.eval import rollout_policy
from icil_paper.seeding import cpu_threads
from icil_paper.sim import make_env
from icil_paper.tables.display import shown_once


# --------------------------------------------------------------------------- chapter 02
def attention_mask_figure(mask: np.ndarray, batch: Mapping[str, Any], b: int):
    """Sequence `b`'s causal mask (L, L), with a line between the padded prompt and the query."""
    prompt_tokens = 2 * batch["prompt_valid"].shape[1]  # padded prompt steps, 2 tokens each
    fig, ax = plt.subplots(figsize=(5.5, 5.5))
    ax.imshow(mask, cmap="gray", interpolation="nearest")
    ax.axvline(prompt_tokens - 0.5, color="#DD8452")
    ax.axhline(prompt_tokens - 0.5, color="#DD8452")
    ax.set_xlabel("key position")
    ax.set_ylabel("query position")
    ax.set_title(f"sequence {b}: causal mask with prompt padding\n(orange line: prompt | query)")
    return shown_once(fig)


def loss_gradient_figure(grads: Any):
    """|dL/dh| at each position of the transformer's output, one line per sequence of (B, L)."""
    fig, ax = plt.subplots(figsize=(12, 2.2))
    for b in range(grads.shape[0]):
        ax.plot(np.asarray(grads[b]), lw=1, label=f"sequence {b}")
    ax.set_xlabel("token position")
    ax.set_ylabel("|dL/dh|")
    ax.legend(loc="upper left", frameon=False)
    ax.set_title("loss gradient at the transformer's output")
    return shown_once(fig)


def loss_coverage(roles: Mapping[str, Any], grads: Any) -> dict[str, int]:
    """The tokens the loss reaches (nonzero in `grads` (B, L)) by kind, from the batch's
    `roles` (`policies.inspection.token_roles`); "unsupervised_reached" is 0 when right."""
    supervised, valid = roles["supervised"], roles["valid"]
    prompt = (roles["segment"] == 0) & valid
    reached = grads > 0
    return {"query_reached": int((reached & supervised).sum()), "query": int(supervised.sum()),
            "prompt_reached": int((reached & prompt).sum()), "prompt": int(prompt.sum()),
            "unsupervised_reached": int((reached & ~supervised).sum())}


def study_metrics(study: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    """Chapter 02's train and eval metrics merged (eval wins), the train's also under "train"."""
    return {**study["train"], **study["eval"], "train": study["train"]}


def training_figure(metrics: Mapping[str, Any], title: str):
    """The total loss and the query steps' action L1 over training (log scale)."""
    m = metrics
    fig, ax = plt.subplots(figsize=(6, 3))
    ax.plot(m["loss_steps"], m["loss"], label="total loss")
    ax.plot(m["loss_steps"], m["action_l1"], label="action L1 (query steps)")
    ax.set_yscale("log")
    ax.set_xlabel("step")
    ax.legend(frameon=False)
    ax.set_title(title)
    return shown_once(fig)


def shown_episode(per_episode: Sequence[Mapping[str, Any]]) -> Mapping[str, Any]:
    """The evaluation episode chapter 02 replays: the first successful one, else the first."""
    return next((e for e in per_episode if e["success"]), per_episode[0])


def replay_episode(policy: Any, demos: Sequence[Any], per_episode: Sequence[Mapping[str, Any]],
                   task: str, max_steps: int) -> tuple[Mapping[str, Any], list, dict]:
    """Replay `shown_episode` with `policy` on the same scene and prompt, on one torch thread
    as in evaluation. Returns (the stored episode, its prompt demos, the rollout's trace)."""
    episode = shown_episode(per_episode)
    prompt = [demos[i] for i in episode["prompt"]]
    env = make_env(task, obs="state", seed=episode["seed"])
    try:
        with cpu_threads(1):
            trace = rollout_policy(policy, env, episode["seed"], prompt, max_steps,
                                   keep_trace=True)
    finally:
        env.close()
    return episode, prompt, trace


def rollout_figure(trace: Mapping[str, Any], demo: Any):
    """A rollout beside its prompt demonstration `demo` (dashed): end effector and actions."""
    eef = np.stack([o["proprio"][:3] for o in trace["obs"]])
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.2))
    axes[0].plot(demo.obs["proprio"][:, 0], demo.obs["proprio"][:, 1], "--", label="prompt demo")
    axes[0].plot(eef[:, 0], eef[:, 1], label="rollout")
    axes[0].set_title("end effector, top view (proprio x, y)")
    axes[0].legend(frameon=False)
    for i, name in enumerate(("dx", "dy", "dz")):
        line, = axes[1].plot(trace["actions"][:, i], label=name)
        axes[1].plot(demo.actions[:, i], "--", color=line.get_color(), lw=0.8)
    axes[1].set_title("position deltas (dashed: prompt demo)")
    axes[1].legend(frameon=False)
    axes[2].plot(demo.actions[:, -1], "--", label="prompt demo")
    axes[2].plot(trace["actions"][:, -1], label="rollout")
    axes[2].set_title("gripper command")
    axes[2].set_ylim(-1.1, 1.1)  # the command's full range, so a constant command reads as one
    axes[2].legend(frameon=False)
    for a in axes[1:]:
        a.set_xlabel("step")
    return shown_once(fig)


# --------------------------------------------------------------------------- chapter 03
def empirical_constant(metrics: Mapping[str, Any], radii: Sequence[float],
                       norm: str = "inf") -> float:
    """An encoder's empirical Lipschitz constant in `norm` ("inf" or "2"), the largest over `radii`."""
    return max(metrics[f"empirical_{norm}_r{r:g}"] for r in radii)


def lipschitz_frame(records: Mapping[str, Mapping[str, Any]],
                    radii: Sequence[float]) -> pd.DataFrame:
    """Chapter 03's table, one row per encoder (`records`: label -> `SeedRecords.seed_means`):
    bounds beside empirical constants, reconstruction error and smoothness."""
    rows = [{"encoder": label,
             "prod softplus(c_l)": m["bound_softplus_product"],
             "bound (inf)": m["bound_inf"], "empirical (inf)": empirical_constant(m, radii),
             "bound (2)": m["bound_2"], "empirical (2)": empirical_constant(m, radii, "2"),
             "recon MSE": m["reconstruction_mse"],
             "least energy": m["latent_least_energy"],
             "standardized LE": m["latent_least_energy_standardized"],
             "latent scale σ": m["latent_scale"]}
            for label, m in records.items()]
    return pd.DataFrame(rows).set_index("encoder")


def bound_figure(records: Mapping[str, Mapping[str, Any]], radii: Sequence[float]):
    """Each encoder's empirical inf-norm constants (one per radius) below its bound (log)."""
    fig, ax = plt.subplots(figsize=(7, 3.5))
    for k, m in enumerate(records.values()):
        ax.plot([k] * len(radii), [m[f"empirical_inf_r{r:g}"] for r in radii], "o", color="C0",
                alpha=0.6, label="empirical, by radius" if k == 0 else None)
        ax.plot(k, m["bound_inf"], "_", color="C3", markersize=30, mew=2,
                label="bound prod ||W_l||_inf" if k == 0 else None)
    ax.set_yscale("log")
    ax.set_xticks(np.arange(len(records)), list(records), rotation=15)
    ax.set_ylabel("Lipschitz constant (inf-norm)")
    ax.legend()
    ax.set_title("Empirical Lipschitz constant vs. its bound")
    return shown_once(fig)


def bound_history_figure(metrics: Mapping[str, Any], title: str):
    """Each layer's bound softplus(c_l) over training, from an encoder's `c_history`."""
    c_hist = np.array(metrics["c_history"])  # (logged steps, layers)
    fig, ax = plt.subplots(figsize=(7, 3.5))
    for layer in range(c_hist.shape[1]):
        ax.plot(metrics["history_step"], c_hist[:, layer], label=f"layer {layer + 1}")
    ax.set_xlabel("training step")
    ax.set_ylabel("softplus(c_l)")
    ax.set_title(title)
    ax.legend()
    return shown_once(fig)


BOUND_RTOL = 1e-5
"""The relative slack of chapter 03's bound check (float32 rounding)."""


def bound_holds(metrics: Sequence[Mapping[str, Any]], radii: Sequence[float],
                rtol: float = BOUND_RTOL) -> bool:
    """Whether every seed's empirical inf-norm constant stays within prod ||W_l||_inf (Eq. 4)."""
    return all(empirical_constant(m, radii) <= m["bound_inf"] * (1 + rtol) for m in metrics)
