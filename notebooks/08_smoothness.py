# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # 8. Table III, Fig. 1 and Fig. 4: smoothness of the latent features
#
# **What the paper claims (Sec. IV-A, Table III, Figs. 1 and 4).** Extracting 500 latent
# action features from the RoboCasa policies, the paper scores each tokenizer by the least
# energy of its latent trajectories (Horn 1983; lower is smoother):
# $\sum_t \lVert z_{t+2} - 2 z_{t+1} + z_t \rVert^2$. LipVQ-VAE is smoothest (0.63), then
# LFQ-VAE (2.34), VQ-VAE, FAST, MLP, and Bin last (12.57), and smoother tokenizers go with
# higher success (Fig. 1). Fig. 4 shows, by t-SNE, the first 10 steps of one trajectory in
# each latent space: LipVQ-VAE's path is the smoothest.
#
# **How it is computed here.** The tokenizers are the ones trained jointly inside Table I's
# ICRT policies ({doc}`chapter 6 <06_table1_kitchen>`), as the paper does; the trajectories are held-out `generated`
# demonstrations (the ones after each data set's training demonstrations). The preset's
# number of features (500 by default, the paper's) is shared equally among the kitchen
# tasks: each task gives the first `feature_steps // tasks` steps of its held-out
# trajectories, so that every task is scored and none weighs more than another; the remainder of the division is not scored, and a task whose held-out
# trajectories are shorter than its share gives what it has. Every training seed scores the
# same steps. What each record scored is stated under the table. Each trajectory's least
# energy is one sample, so the mean comes with a bootstrap interval. The raw score grows with the
# square of the latent scale (multiply a latent by 10 and it scores 100 times higher), so
# the table also shows the **standardized** least energy, computed on the latents divided by
# their overall standard deviation $\sigma$ over the held-out set, and $\sigma$ itself:
# a low raw score can be a small latent rather than a smooth one ({doc}`chapter 11 <11_is_it_smoothness>` asks which).
# {doc}`Chapter 5 <05_action_tokenizers>` measures the same tokenizers trained alone, as a supplement.

# %% tags=["hide-input"]

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import Markdown, display

from icil_paper.book.recording import record_latent_trajectories
from icil_paper.book.viewer import show_recording
from icil_paper.config import get_preset
from icil_paper.paper.table_iii import (
    feature_sampling_sentence,
    smoothness_success_figure,
    tsne_paths,
)
from icil_paper.results import results_root
from icil_paper.tables.assemble import format_cell
from icil_paper.tables.book import claims_figure, load_table, verdicts
from icil_paper.tables.display import show_comparison, source_label

preset = get_preset()
smooth = load_table(preset, "III")
success = load_table(preset, "I")

# %% [markdown]
# ## Table III: least energy of the latent features

# %%
show_comparison(smooth, "least_energy")
rows = []
for source, result in smooth.items():
    for row in result.spec.rows:
        cell = result.cell(row.label, "least_energy")
        if cell is None or cell.estimate is None:
            continue
        std = cell.extra["standardized_estimate"]
        codes = [m.get("codes_used") for m in cell.extra["metrics"]]
        rows.append({"source": source_label(source, result.preset), "tokenizer": row.label,
                     "raw": format_cell(cell, 3),
                     "standardized": f"{std.value:.3f} [{std.low:.3f}, {std.high:.3f}]",
                     "latent scale σ": round(float(np.mean(cell.extra["latent_scale"])), 4),
                     "codes used": None if codes[0] is None else round(float(np.mean(codes)), 1),
                     "features": cell.extra["metrics"][0]["n_features"]})
display(pd.DataFrame(rows).set_index(["source", "tokenizer"]) if rows else
        Markdown("*No smoothness records yet.*"))
display(Markdown("**What was scored** (from the features records):\n\n"
                 + feature_sampling_sentence(smooth)))

# %% [markdown]
# ## Fig. 1: smoothness against success
#
# Each point is one ICRT tokenizer: its least energy (Table III) against its average success
# (Table I), both with 95% intervals. The paper's points are on their own axis: its scores
# come from other latents and another simulator, so only the ordering compares.

# %% tags=["hide-input"]
display(smoothness_success_figure(smooth, success))
display(smoothness_success_figure(smooth, success, standardized=True))

# %% [markdown]
# ## Fig. 4: one trajectory through every latent space (t-SNE)
#
# The first steps of the first held-out trajectory, embedded by each policy's tokenizer and
# projected to 2-D by t-SNE (scikit-learn), coloured by time; seed 0's policies of this
# build. The recording shows the same paths with the action curves on a time line.

# %%
build = smooth["this build"]
paths = tsne_paths(build)
if paths:
    fig, axes = plt.subplots(1, len(paths), figsize=(2.6 * len(paths), 2.8))
    for ax, (label, xy) in zip(np.atleast_1d(axes), paths.items(), strict=False):
        ax.plot(xy[:, 0], xy[:, 1], color="0.7", zorder=1)
        ax.scatter(xy[:, 0], xy[:, 1], c=np.arange(len(xy)), cmap="viridis", zorder=2)
        ax.set_title(label.split("+")[1])
        ax.set_xticks([]), ax.set_yticks([])
    fig.tight_layout()
    plt.show()
    first = build.cell(build.spec.rows[0].label, "least_energy").extra["metrics"][0]
    recording = record_latent_trajectories(
        results_root() / preset.name / "smoothness" / "fig4_tsne.rrd",
        np.asarray(first["view_actions"]), paths,
        title="Fig. 4: the first steps of one held-out trajectory in each tokenizer's "
              "latent space (t-SNE, colour = time)")
    display(show_recording(recording["rrd"], recording["png"], label="Fig. 4 (t-SNE paths)"))
else:
    display(Markdown("*No smoothness records yet.*"))

# %% [markdown]
# ## Which claims held

# %% tags=["hide-input"]
display(Markdown(verdicts(preset, "III")))
display(claims_figure(preset, "III"))
