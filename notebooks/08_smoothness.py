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
# number of features (500 by default, the paper's) is shared equally among Table I's 13
# Meta-World tasks: each task gives the first `feature_steps // tasks` steps of its held-out
# trajectories, so that every task is scored and none weighs more than another; the remainder of the division is not scored, and a task whose held-out
# trajectories are shorter than its share gives what it has. Every training seed scores the
# same steps. What each record scored is stated under the table. Each trajectory's least
# energy is one sample, so the mean comes with a bootstrap interval. The raw score grows with the
# square of the latent scale (multiply a latent by 10 and it scores 100 times higher), so
# the table also shows the **standardized** least energy, computed on the latents divided by
# their overall standard deviation $\sigma$ over the held-out set, and $\sigma$ itself:
# a low raw score can be a small latent rather than a smooth one ({doc}`chapter 11 <11_is_it_smoothness>` asks which).
# {doc}`Chapter 5 <05_action_tokenizers>` measures the same tokenizers trained alone, as a supplement.
#
# The tables and figures show **the paper**, **our run** ({glue:text}`ch08_seeds` seeds a row,
# results committed under `results/reference/`; a row whose records
# are not there yet reads "not run") and **the quick run** (CI's small
# preset: it tests the code, not the paper; in a collapsed
# block).

# %% tags=["remove-cell"]
from myst_nb import glue

from icil_paper.book.report import committed_design

seeds = committed_design("III")["seeds"].values() or [0]
glue("ch08_seeds", f"{min(seeds)}" if min(seeds) == max(seeds) else f"{min(seeds)} to {max(seeds)}")

# %% tags=["hide-input"]
from IPython.display import Markdown, display

from icil_paper.book.experiments import (
    FIG4_TITLE,
    NO_SMOOTHNESS,
    standardized_frame,
    tsne_actions,
    tsne_figure,
)
from icil_paper.book.report import BUILD, claims_figure, load_table, verdicts
from icil_paper.config import get_preset
from icil_paper.paper.table_iii import (
    feature_sampling_frame,
    smoothness_success_figure,
    tsne_paths,
)
from icil_paper.results import results_root
from icil_paper.tables.display import collapsed_frame, show_comparison, show_frame_or
from icil_paper.viz.recording import record_latent_trajectories
from icil_paper.viz.viewer import show_recording

preset = get_preset()
smooth = load_table(preset, "III")
success = load_table(preset, "I")

# %% [markdown]
# ## Table III: least energy of the latent features

# %%
show_comparison(smooth, "least_energy")
show_frame_or(standardized_frame(smooth), NO_SMOOTHNESS)
display(collapsed_frame("What was scored, per row and seed (from the features records). Open to see it.", feature_sampling_frame(smooth)))

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
build = smooth[BUILD]
paths = tsne_paths(build)
if not paths:
    display(Markdown(NO_SMOOTHNESS))
else:
    display(tsne_figure(paths))
    recording = record_latent_trajectories(
        results_root() / preset.name / "smoothness" / "fig4_tsne.rrd", tsne_actions(build),
        paths, title=FIG4_TITLE)
    display(show_recording(recording["rrd"], recording["png"], label="Fig. 4 (t-SNE paths)"))

# %% [markdown]
# ## Which claims held

# %% tags=["hide-input"]
display(Markdown(verdicts(preset, "III")))
display(claims_figure(preset, "III"))
