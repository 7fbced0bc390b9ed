"""The tasks and their demonstrations (chapter 04) and the tokenizers trained alone (05).

    display(task_registry())                               # chapter 04
    summary = demo_summary(demos, demo_stats(demos))       # both sources, per task
    properties, smoothness = tokenizer_frames(seeds, paper_tokenizer_smoothness())  # 05

Figures are closed before they are returned, so each shows once, where displayed.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import display

from icil_paper import sim, stats
from icil_paper.book.studies import SeedRecords
from icil_paper.data import SOURCES, load_demos, zero_shot_split
from icil_paper.data.stats import data_set_stats, keep_rate
from icil_paper.paper.table_iii import TABLE_III_SMOOTHNESS
from icil_paper.tables.display import shown_once

# --------------------------------------------------------------------------- chapter 04
DATA_TASKS = ("metaworld/drawer-open", "maniskill/pick_cube")
"""The tasks whose data sets chapter 04 examines in full, both sources."""


def data_tasks() -> list[str]:
    """`DATA_TASKS` that are registered here."""
    return [t for t in DATA_TASKS if t in sim.all_tasks()]


def task_registry() -> pd.DataFrame:
    """Every registered task: its suite and the (proprio, object) widths of its observations."""
    return pd.DataFrame([{"task": t, "suite": sim.suite_of(t),
                          "proprio, object": sim.obs_dims(sim.suite_of(t))}
                         for t in sim.all_tasks()])


SHOWCASE_COLUMNS = ["task", "instruction", "success", "length", "horizon", "seconds"]
"""The showcase records' columns chapter 04 lists."""


def showcase_frame(showcase: Mapping[str, Mapping[str, Any]]) -> pd.DataFrame:
    """One row per shown task (`studies.showcase_study`): `SHOWCASE_COLUMNS`."""
    return pd.DataFrame(showcase.values())[SHOWCASE_COLUMNS]


def first_frames_figure(showcase: Mapping[str, Mapping[str, Any]], cols: int = 6):
    """A grid of every shown task's first scene (the picture its showcase record names)."""
    rows = int(np.ceil(len(showcase) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(2.6 * cols, 2.8 * rows), squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    for ax, (task, entry) in zip(axes.flat, showcase.items(), strict=False):
        ax.imshow(plt.imread(entry["frame"]))
        ax.set_title(task, fontsize=8)
    fig.suptitle("first scene of every task (seed of demo 0)")
    return shown_once(fig)


def showcase_recordings(showcase: Mapping[str, Mapping[str, Any]]) -> dict[str, tuple[str, str]]:
    """{task: (its rerun recording, its static picture)}, for `viewer.show_recordings`."""
    return {task: (entry["rrd"], entry["picture"]) for task, entry in showcase.items()}


def load_data_sets(data_sets: Mapping[tuple[str, str], str | Path], tasks: Sequence[str],
                   limit: int) -> dict[tuple[str, str], list]:
    """{(task, source): the first `limit` demonstrations} of `tasks`, without images, read
    from `data_sets` ({(task, source): file}, `studies.demo_stage`)."""
    return {(task, source): load_demos(data_sets[task, source], action_dim=sim.ACTION_DIM,
                                       limit=limit, images=False)
            for task in tasks for source in SOURCES}


KEPT_COLUMN = "{source}: success over data-set scenes"
"""The header of a source's keep rate in `keep_rates`."""


def keep_rates(data_sets: Mapping[tuple[str, str], str | Path], limit: int) -> pd.DataFrame:
    """Task x source: the share of attempts kept as demonstrations (`data.stats.keep_rate`)."""
    rows = []
    for (task, source), path in data_sets.items():
        demos = load_demos(path, action_dim=sim.ACTION_DIM, limit=limit, images=False)
        rows.append({"task": task, "source": source, "keep rate": keep_rate(demos)})
    kept = pd.DataFrame(rows).pivot(index="task", columns="source", values="keep rate")
    kept.columns = [KEPT_COLUMN.format(source=c) for c in kept.columns]
    return kept


def demo_stats(demos: Mapping[tuple[str, str], Sequence[Any]]) -> pd.DataFrame:
    """One row per demonstration of `load_data_sets`' data sets (`data.stats.data_set_stats`)."""
    return pd.DataFrame([row for ds in demos.values() for row in data_set_stats(ds)])


def demo_summary(demos: Mapping[tuple[str, str], Sequence[Any]],
                 stats_frame: pd.DataFrame) -> pd.DataFrame:
    """By (task, source): demonstrations, length, smoothness and gripper means, keep rate."""
    summary = stats_frame.groupby(["task", "source"]).agg(
        demos=("length", "size"), mean_length=("length", "mean"), std_length=("length", "std"),
        least_energy_per_step=("least_energy_per_step", "mean"),
        still_fraction=("still_fraction", "mean"),
        gripper_switches=("gripper_switches", "mean"))
    summary["keep_rate"] = [keep_rate(demos[key]) for key in summary.index]
    return summary


SUMMARY_HEADERS = {"mean_length": "mean length", "std_length": "std",
                   "least_energy_per_step": "least energy / step", "still_fraction": "still",
                   "gripper_switches": "gripper switches", "keep_rate": "kept"}
"""Short headers for `demo_summary`, so that the table fits the page."""


def show_demo_summary(summary: pd.DataFrame) -> None:
    """Display `demo_summary` with short headers and three significant digits."""
    with pd.option_context("display.float_format", "{:.3g}".format):
        display(summary.rename(columns=SUMMARY_HEADERS))


def demos_figure(demos: Mapping[tuple[str, str], Sequence[Any]], stats_frame: pd.DataFrame,
                 tasks: Sequence[str]):
    """Both sources' demonstration lengths, then demo 0's x and z deltas for each of `tasks`."""
    colors = dict(zip(SOURCES, ("tab:blue", "tab:orange"), strict=True))
    fig, axes = plt.subplots(1, 1 + len(tasks), figsize=(5 * (1 + len(tasks)), 3.4))
    axes = np.atleast_1d(axes)
    bins = np.linspace(stats_frame.length.min(), stats_frame.length.max() + 1, 13)
    for source, color in colors.items():
        axes[0].hist(stats_frame[stats_frame.source == source].length, bins=bins, color=color,
                     alpha=0.6, label=source)
    axes[0].set(xlabel="demo length [steps]", ylabel="demos",
                title=f"demo lengths ({', '.join(t.split('/')[1] for t in tasks)})")
    axes[0].legend(fontsize=8)
    for ax, task in zip(axes[1:], tasks, strict=True):
        for source, color in colors.items():
            demo = demos[task, source][0]
            ax.plot(demo.actions[:, 0], color=color, label=f"{source} dx")
            ax.plot(demo.actions[:, 2], color=color, ls="--", label=f"{source} dz")
        ax.set(xlabel="step", ylabel="action", title=f"{task}: demo 0 of each source")
        ax.legend(fontsize=7)
    return shown_once(fig)


def zero_shot_lines() -> str:
    """Meta-World's zero-shot split (ML45), or why it is not available here."""
    try:
        train_tasks, held_out = zero_shot_split()
    except ImportError as exc:
        return f"Meta-World suite unavailable: {exc}"
    return f"zero-shot: train on {list(train_tasks)}\n           hold out {list(held_out)}"


EXPERT_REQUIREMENT = 0.9
"""The success an expert must reach over random scenes (the paper's data need it)."""


# --------------------------------------------------------------------------- chapter 05
TOKENIZER_SCORES = ("least_energy", "least_energy_standardized")
"""The latent smoothness scores chapter 05 ranks the tokenizers by (lower is smoother)."""

LOW_USAGE = 0.1
"""A codebook that uses under this share of its codes on held-out data has collapsed."""


def paper_tokenizer_smoothness() -> dict[str, float]:
    """The paper's least energy of each tokenizer (Table III), by tokenizer name ("lipvq")."""
    return {row.split("+")[1]: v for row, v in TABLE_III_SMOOTHNESS.items()}


TOKENIZER_FORMATS = {"codebook": "{:,.0f}", "usage": "{:.1%}", "perplexity": "{:.1f}",
                     "tokens/step": "{:.2f}", "encode act/s": "{:,.0f}",
                     "latent scale σ": "{:.3g}", "recon MSE": "{:.3g}", "decode MSE": "{:.3g}",
                     "paper least energy": "{:.2f}"}
"""How chapter 05's tables print each column."""


def _styled(rows: list[dict[str, Any]]):
    frame = pd.DataFrame(rows).set_index("tokenizer")
    return frame.style.format({c: f for c, f in TOKENIZER_FORMATS.items() if c in frame.columns},
                              na_rep="-")


def tokenizer_frames(seeds: SeedRecords, paper_smoothness: Mapping[str, float]):
    """Chapter 05's two styled tables (properties, smoothness), means over training seeds."""
    properties, smoothness = [], []
    for label in seeds.records:
        properties.append({
            "tokenizer": label,
            "recon MSE": seeds.mean(label, "reconstruction_mse"),
            "decode MSE": seeds.mean(label, "decode_mse"),
            "codebook": seeds.mean(label, "codebook_size"),
            "usage": seeds.mean(label, "usage"),
            "perplexity": seeds.mean(label, "perplexity"),
            "tokens/step": seeds.mean(label, "tokens_per_step"),
            "codes/level": seeds.per_level(label),
            "encode act/s": seeds.mean(label, "encode_actions_per_s"),
        })
        smoothness.append({
            "tokenizer": label,
            "least energy": seeds.with_interval(label, "least_energy"),
            "standardized": seeds.with_interval(label, "least_energy_standardized"),
            "latent scale σ": seeds.mean(label, "latent_scale"),
            "paper least energy": paper_smoothness.get(label),
        })
    return _styled(properties), _styled(smoothness)


def smoothness_figure(seeds: SeedRecords, paper_smoothness: Mapping[str, float],
                      keys: Sequence[str] = TOKENIZER_SCORES):
    """Each tokenizer's mean of each of `keys` with its 95% interval, then the paper's."""
    labels = list(seeds.records)
    fig, axes = plt.subplots(1, len(keys) + 1, figsize=(14, 3.6))
    for ax, key in zip(axes[:-1], keys, strict=True):
        ests = [stats.score_mean(seeds.scores(k, key)) for k in labels]
        ax.bar(range(len(labels)), [e.value for e in ests],
               yerr=[[e.value - e.low for e in ests], [e.high - e.value for e in ests]],
               capsize=3, color=["C3" if k == "lipvq" else "C0" for k in labels])
        ax.set_xticks(range(len(labels)), labels, rotation=60)
        ax.set_yscale("log")
        ax.set_title(key.replace("_", " ") + " (ours, lower is smoother)")
    paper_labels = [k for k in labels if k in paper_smoothness]
    axes[-1].bar(range(len(paper_labels)), [paper_smoothness[k] for k in paper_labels],
                 color="C7")
    axes[-1].set_xticks(range(len(paper_labels)), paper_labels, rotation=60)
    axes[-1].set_title("least energy (the paper, Table III)")
    return shown_once(fig)
