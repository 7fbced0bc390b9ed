# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # 6. Table I: in-context imitation on Meta-World
#
# **What the paper claims (Sec. IV-A, Table I).** On RoboCasa's seven skill families,
# ICRT with LipVQ-VAE reaches 0.530 average success: 5.3 points above BC-Transformer, 4.1
# above the second-best tokenizer (LFQ-VAE), 8.8 above the worst (ICRT's own MLP), which
# itself falls 3.5 points below BC-Transformer. MCR and ACT trail far behind.
#
# **How it is computed here.** RoboCasa's kitchens cannot be downloaded, so the seven skill
# families are 13 tasks of Meta-World, a public benchmark, with its scripted experts
# ({doc}`chapter 4 <04_tasks_and_demonstrations>` says which tasks stand for which family),
# and the MimicGen data is their `generated` demonstrations, as many per task as the
# paper's regime asks (the pilot below chooses the count). A family's success is the mean
# over its tasks. Each row is one multi-task policy trained on all 13 tasks, as in the
# paper, and rolled out per task on layouts it has not seen (training, prompt and evaluation
# layouts come from disjoint seeds); training seed k of every row plays the same episodes
# (in the reference run each seed k has a scene set of its own, so scene luck averages out
# over seeds; in the small build every seed plays one set), so rows are compared seed by
# seed on the same scenes. ICRT's prompt is one demonstration of the task from the
# generated data set. MCR learns from camera images (fewer demonstrations and episodes,
# since rendering costs much more than a state step on CPU); every other row learns from
# low-dimensional state. Sizes, steps and episodes are the preset's
# ({doc}`chapter 1 <01_environment>` lists them).
#
# The table shows three sources: **the paper**, **the reference run** (`reference` preset,
# whose design is stated below; its records are committed under `results/reference/`; those
# committed so far were made on the robosuite kitchen suite that stood in for RoboCasa
# before Meta-World, and are shown labelled as that older protocol's until the reference run
# is repeated on Meta-World) and **this build** (the preset the book was built with; on CI
# the `small` preset, whose short training makes its numbers a test of the code, not
# evidence). Every number comes with its
# 95% interval (`icil_paper.stats`): a t interval on the per-seed values where a row has
# several training seeds; for a single seed, the episodes' noise only (and no comparison
# with it is decided).

# %% tags=["hide-input"]
from IPython.display import Markdown, display

from icil_paper.book.experiments import design_paragraph, paper_lipvq_range
from icil_paper.book.report import REFERENCE, claims_figure, design_sentence, load_table, verdicts
from icil_paper.config import get_preset
from icil_paper.tables.display import show_comparison, show_motion, show_values, success_figure

preset = get_preset()  # reads ICIL_PRESET
results = load_table(preset, "I")  # computes what this build's results store lacks
display(Markdown(design_paragraph(preset.name, design_sentence(get_preset(REFERENCE)),
                                  design_sentence(preset))))

# %% [markdown]
# ## The task scale: the earlier kitchen run's pilot
#
# A family where every row succeeds always, or never, cannot tell the rows apart, and
# averaging it in shrinks every difference. Before the earlier reference run on the kitchen
# suite, a one-seed pilot (`python -m icil_paper.planning.pilot`) trained the rows that bound
# this table's range at several settings of the reference preset and evaluated them as the
# table does, and that run took the setting that kept the best row away from 0 and 1 on the
# most families. Its stored record, below, is that kitchen run's (its settings are named
# `kitchen_...`): a record of the older protocol, not of the Meta-World tasks, whose data
# and training budget the regime pilot of the next section sets. One seed: these numbers
# place a family between 0 and 1, they do not rank the rows.

# %% tags=["hide-input"]
from icil_paper.planning.pilot import show_pilot

show_pilot(table="I")

# %% [markdown]
# ## The paper's regime: a pilot on seeds the reference run does not use
#
# In the paper, after 500K iterations on MimicGen's many demonstrations, ICRT + LipVQ-VAE
# lies well inside (0, 1) on every RoboCasa family (below): trained to its plateau, on
# plenty of data, and neither at the floor nor at the ceiling. The regime pilot
# (`python -m icil_paper.planning.pilot regime`) sets the reference preset's data and
# training budget from two curves, on training seeds, demonstration sets and scene sets that
# the reference run never uses:
#
# - **the data curve**: BC-Transformer, the row that is not in-context and leans most on the
#   amount of data, trained on several numbers of demonstrations per task. The preset takes
#   the count where more demonstrations no longer raise its success beyond noise, so that
#   no baseline is starved of data (the earlier kitchen runs trained on 3 demonstrations
#   for most tasks);
# - **the learning curve**: ICRT + LipVQ-VAE at several training budgets. The preset takes
#   the budget where the curve levels off (no gain beyond noise at the next budget), and the
#   difficulty of each family is read from ICRT + LipVQ-VAE's level there.
#
# Neither choice compares two rows: the count comes from BC-Transformer's curve alone, the
# budget and the difficulty from ICRT + LipVQ-VAE's alone, so the pilot cannot select for a
# difference the table reports. At the chosen budget the pilot also trains the rows
# reported beside ICRT + LipVQ-VAE (ICRT + MLP, ICRT + VQ-VAE and BC-Transformer) and ACT +
# LipVQ-VAE on each ManiSkill task; a budget a row was not trained at reads "not trained".
# The numbers below are read from the pilot's stored record (`results/bench/regime.json`).

# %% tags=["hide-input"]
from icil_paper.planning.pilot import regime_summary

display(Markdown(paper_lipvq_range()))
regime, regime_text = regime_summary()
if regime is not None:
    display(regime.style.format(na_rep="not trained", precision=3))
display(Markdown(regime_text))

# %% [markdown]
# ## Average success over the Meta-World tasks

# %% tags=["hide-input"]
from icil_paper.tables.display import seed_correlation_sentence

show_comparison(results, "avg")
display(success_figure(results, "avg", title="Table I: average success over the Meta-World tasks"))

# %% [markdown]
# Seed k of every row trains on demonstration set k and plays scene set k, and the ICRT
# rows of seed k start from the same backbone and draw the same batches (common random
# numbers).

# %% tags=["hide-input"]
display(Markdown(seed_correlation_sentence(results)))

# %% [markdown]
# **Codebook use of the VQ-family rows**, per training seed: the distinct codes each trained
# tokenizer gives the held-out trajectories of Table III (chapter 8), of its K, and the
# perplexity of their distribution (how many equally used codes would give it).

# %% tags=["hide-input"]
from icil_paper.tables.display import show_codebook_use

show_codebook_use(results)

# %% [markdown]
# ## What a prompt adds over the instruction
#
# Every row reads the task's language instruction (a learned bag of words standing in for
# the paper's CLIP); ICRT reads a demonstration of the task besides. The prompt ablation
# (chapter 10) gives ICRT + LipVQ-VAE another task's prompt, or only the first steps of its
# own; beside it, the baselines that read the instruction and no prompt. A prompt that
# carries the task lifts ICRT above them; a wrong one shows what is left of it.

# %% tags=["hide-input"]
from icil_paper.paper.prompt_ablation import prompt_beside_baselines

display(prompt_beside_baselines(results, load_table(preset, "prompt")))

# %% [markdown]
# ## How smoothly the robot moves
#
# The paper measures smoothness in the tokenizer's latent space (Table III); the rollouts
# also say how smoothly the arm itself moved. Every episode's end-effector path is scored
# by its log dimensionless jerk (LDLJ) and the spectral arc length of its speed profile
# (SPARC), both higher for smoother motion (a minimum-jerk reach scores -6.6 and -1.4),
# and its executed commands by their mean squared second difference (action jerk, lower
# for smoother commands); `icil_paper.metrics` gives the formulas and their sources. Each
# number is the mean over the row's seeds of each seed's mean over its episodes, with the
# seed as the unit as for success.

# %% tags=["hide-input"]
show_motion(results, "avg")

# %% [markdown]
# ## By skill family
#
# Point values per family (the intervals of single families are wide at these episode
# counts); the paper's row first.

# %% tags=["hide-input"]
show_values(results)

# %% [markdown]
# ## Which claims held
#
# Generated from the claims ledger ({doc}`chapter 0 <00_claims_ledger>`): each claim is a difference of two rows on
# the same episodes, with its paired 95% interval.

# %% tags=["hide-input"]
display(Markdown(verdicts(preset, "I")))
display(claims_figure(preset, "I"))
