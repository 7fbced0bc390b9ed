# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # 7. Table II: action tokenizers inside ACT on ManiSkill
#
# **What the paper claims (Sec. IV-A, Table II).** To test tokenizers beyond in-context
# imitation, the paper replaces ACT's CVAE action encoder with each tokenizer on ManiSkill's
# Pick, Push and Stack Cube. ACT + LipVQ-VAE averages 0.617: the best tokenizer, 6 points
# above LFQ-VAE and 19.7 above plain ACT.
#
# **How it is computed here.** ManiSkill 3 runs for real (CPU physics). Its demonstrations
# are ManiSkill's own motion-planning solutions, converted to the 7-D end-effector deltas
# every policy here acts in ({doc}`chapter 4 <04_tasks_and_demonstrations>`). One policy per task, as ManiSkill's baselines train
# them. In ACT + tokenizer the decoder regresses the tokenizer's embedding of the action
# chunk and acts through the tokenizer's `decode`: the decoder network for MLP, VQ-VAE,
# LFQ-VAE and LipVQ-VAE, and a learned MLP head for Bin and FAST (bin centres and FAST's
# inverse DCT start from discrete codes, which a regressed latent does not give), so ACT +
# Bin and ACT + FAST act through an MLP on a predicted latent. MCR learns from RGB-D images
# through the depth channel added to its ResNet, as the paper describes.
#
# The tables show **the paper**, **our run** ({glue:text}`ch07_seeds` seeds a row,
# results committed under `results/reference/`; a row whose records
# are not there yet reads "not run") and **the quick run** (CI's small
# preset: it tests the code, not the paper; in a collapsed
# block).

# %% tags=["remove-cell"]
from myst_nb import glue

from icil_paper.book.report import committed_design

seeds = committed_design("II")["seeds"].values() or [0]
glue("ch07_seeds", f"{min(seeds)}" if min(seeds) == max(seeds) else f"{min(seeds)} to {max(seeds)}")

# %% tags=["hide-input"]
from IPython.display import Markdown, display

from icil_paper.book.report import claims_figure, load_table, verdicts
from icil_paper.config import get_preset
from icil_paper.paper.table_ii import maniskill_settings
from icil_paper.tables.display import show_comparison, show_motion, show_values, success_figure

preset = get_preset()
results = load_table(preset, "II")
demos, steps, episodes = maniskill_settings(preset)  # this preset's single-task runs
print(f"each state policy: {demos} demos a task, {steps} steps, {episodes} episode(s) a task")
print(f"MCR: {preset.tables.image_demos_per_task} image demonstrations a task")

# %% tags=["hide-input"]
show_comparison(results, "avg")
display(success_figure(results, "avg", title="Table II: average success over the three cube tasks"))

# %% [markdown]
# ## The task scale: the pilot behind the reference preset
#
# A task where every row succeeds always, or never, cannot tell the rows apart, and
# averaging it in shrinks every difference. Before our run, a one-seed pilot
# (`make pilot`) trained ACT, the row every other row of this table
# builds on, at several settings of the reference preset and evaluated it as the table
# does; the
# reference preset takes the setting that keeps the best row away from 0 and 1 on the most
# tasks (the preset's docstring gives the reasoning). One seed: these numbers place a
# task between 0 and 1, they do not rank the rows.

# %% tags=["hide-input"]
from icil_paper.planning.pilot import show_pilot

show_pilot(table="II")

# %% [markdown]
# ## How smoothly the robot moves
#
# Beside success, the smoothness of the motion itself: each episode's end-effector path
# scored by LDLJ and SPARC (higher: smoother) and its commands by their action jerk (lower:
# smoother), as in {doc}`chapter 6 <06_table1_kitchen>`, averaged per seed over the three
# tasks' episodes.

# %% tags=["hide-input"]
show_motion(results, "avg")

# %% [markdown]
# ## By task

# %% tags=["hide-input"]
show_values(results)

# %% [markdown]
# ## Which claims held

# %% tags=["hide-input"]
display(Markdown(verdicts(preset, "II")))
display(claims_figure(preset, "II"))
