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
# layouts come from disjoint seeds); training seed k of every row trains on demonstration
# set k, plays scene set k and, for the ICRT rows, starts from the same backbone and draws
# the same batches, so rows are compared seed by seed (common random numbers). ICRT's prompt is one demonstration of the task from the
# generated data set. MCR learns from camera images (fewer demonstrations and episodes,
# since rendering costs much more than a state step on CPU); every other row learns from
# low-dimensional state. Sizes, steps and episodes are the preset's
# ({doc}`chapter 1 <01_environment>` lists them).
#
# The table shows three sources: **the paper**; **our run** ({glue:md}`ch06_seeds` seeds a
# row, on the Meta-World tasks above, results committed under `results/reference/`); and
# **the quick run** (CI's small preset: it tests the code, not the paper). The earlier runs
# on the robosuite kitchen suite are kept as records of their protocols, and
# {doc}`chapter 0 <00_claims_ledger>` sets their decisions beside ours. Every number comes
# with its 95% interval (`icil_paper.stats`): a t
# interval on the per-seed values where a row has several training seeds; for a single
# seed, the episodes' noise only (and no comparison with it is decided).

# %% tags=["hide-input"]
from IPython.display import Markdown, display
from myst_nb import glue

from icil_paper.book.report import claims_figure, committed_design, load_table, verdicts
from icil_paper.config import get_preset
from icil_paper.paper.table_i import TABLE_I_ROBOCASA
from icil_paper.tables.display import show_comparison, show_motion, show_values, success_figure

preset = get_preset()  # reads ICIL_PRESET
results = load_table(preset, "I")  # computes what this build's results store lacks
design = committed_design("I")  # the seeds our run reached, read from results/reference/
low, high = min(design["seeds"].values()), max(design["seeds"].values())
glue("ch06_seeds", Markdown(f"{low}" if low == high else f"{low} to {high}"), display=False)
families = [v for k, v in TABLE_I_ROBOCASA["icrt+lipvq"].items() if k != "avg"]
glue("ch06_paper_low", min(families), display=False)
glue("ch06_paper_high", max(families), display=False)

# %% [markdown]
# ## How one cell is made
#
# A cell of the table is a row trained on the 13 tasks and rolled out on each. Training is
# `train_policy` (`src/icil_paper/train/loop.py`): it builds the policy, fits its tokenizer
# where it needs fitting, and repeats one optimiser step until the preset's step count:
#
# ```{literalinclude} /src/icil_paper/train/loop.py
# :pyobject: _step
# :caption: src/icil_paper/train/loop.py (one training step)
# ```
#
# The policy's `forward` is the loss of chapter 2: the chunk of actions predicted at every
# query observation token against the demonstration's, plus the tokenizer's own losses.
# Evaluation is `rollout_batch` (`src/icil_paper/eval/rollouts.py`): every episode of a task
# resets its environment from an evaluation seed, the policy reads the prompt, then acts one
# step at a time until the task reports success or the horizon ends.
#
# :::{dropdown} `rollout_batch`: episodes in lockstep (click to open)
# ```{literalinclude} /src/icil_paper/eval/rollouts.py
# :pyobject: rollout_batch
# :caption: src/icil_paper/eval/rollouts.py (the rollout loop)
# ```
# :::
#
# Both run below at toy scale: ICRT + LipVQ-VAE trained for 20 steps on four demonstrations
# of drawer-open, then two episodes of 40 steps, prompted with a demonstration each. Twenty
# steps teach nothing; the table's rows train for the preset's thousands.

# %%
# teaches: one training step and the rollout loop, at toy scale
import dataclasses

from icil_paper.data import ensure_demos, load_demos
from icil_paper.eval.rollouts import rollout_batch
from icil_paper.paper.icrt_demo import ICRT_DEMO_TASK, icrt_specs
from icil_paper.sim import make_env
from icil_paper.train import train_policy

run, _ = icrt_specs(preset)  # chapter 2's cell: ICRT + LipVQ-VAE on drawer-open
demos = load_demos(ensure_demos(preset, ICRT_DEMO_TASK, "generated",
                                n=run.data.demos_per_task), limit=4)
short = dataclasses.replace(run.train, steps=20, log_every=5)
toy = dataclasses.replace(run, train=short)
trained = train_policy(toy, run_dir=None, demos=demos, progress=False)  # stores nothing
print("loss by step:", [(h["step"], round(h["loss"], 3)) for h in trained.history])
envs = [make_env(ICRT_DEMO_TASK, obs="state", seed=s) for s in (1000, 1001)]
episodes = rollout_batch(trained.policy, envs, seeds=[1000, 1001],
                         prompts=[demos[:1], demos[1:2]], max_steps=40)
for env in envs:
    env.close()
print("episodes:", [(e["success"], e["steps"]) for e in episodes], "(success, steps)")

# %% [markdown]
# ## The task scale: the earlier kitchen run's pilot
#
# :::{dropdown} What the kitchen run's pilot was (click to open)
# A family where every row succeeds always, or never, cannot tell the rows apart, and
# averaging it in shrinks every difference. Before the earlier reference run on the kitchen
# suite, a one-seed pilot (`make pilot`) trained the rows that bound
# this table's range at several settings of the reference preset and evaluated them as the
# table does, and that run took the setting that kept the best row away from 0 and 1 on the
# most families. Its stored record, below, is that kitchen run's (its settings are named
# `kitchen_...`): a record of the older protocol, not of the Meta-World tasks, whose data
# and training budget the regime pilot of the next section sets. One seed: these numbers
# place a family between 0 and 1, they do not rank the rows.
# :::

# %% tags=["hide-cell"]
from icil_paper.planning.pilot import show_pilot

show_pilot(table="I")

# %% [markdown]
# ## The paper's regime: a pilot on seeds the reference run does not use
#
# :::{dropdown} How the pilot chose the data and the training budget (click to open)
# In the paper, after 500K iterations on MimicGen's many demonstrations, ICRT + LipVQ-VAE
# lies well inside (0, 1) on every RoboCasa family: trained to its plateau, on
# plenty of data, and neither at the floor nor at the ceiling: from
# {glue:text}`ch06_paper_low:.2f` to {glue:text}`ch06_paper_high:.2f` over its seven families. The regime pilot
# (`make pilot PILOT_ARGS=regime`) sets the reference preset's data and
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
# :::

# %% tags=["hide-cell"]
from icil_paper.planning.pilot import regime_summary

regime, regime_text = regime_summary()
if regime is not None:
    display(regime.style.format(na_rep="not trained", precision=3))
display(Markdown(regime_text))

# %% [markdown]
# ## Average success over the Meta-World tasks

# %% tags=["hide-input"]
show_comparison(results, "avg")
display(success_figure(results, "avg", title="Table I: average success over the Meta-World tasks"))

# %% tags=["remove-cell"]
import numpy as np

from icil_paper.tables.display import seed_correlations

r = seed_correlations(next(iter(results.values())))  # our run's
icrt = [v for (a, b), v in r.items() if a.startswith("icrt") and b.startswith("icrt")]
glue("ch06_r_pairs", len(r))
glue("ch06_r_mean", f"{np.mean(list(r.values())):.2f}" if r else "n/a")
glue("ch06_r_icrt_pairs", len(icrt))
glue("ch06_r_icrt", f"{np.mean(icrt):.2f}" if icrt else "n/a")

# %% [markdown]
# :::{dropdown} How much pairing by seed index gains (click to open)
# Seed k of every row shares its demonstration set, its evaluation scenes and, for the ICRT
# rows, its backbone's first weights: the larger the correlation of two rows' per-seed
# success at the same seed index, the more a paired comparison gains. In our run the mean
# correlation is {glue:text}`ch06_r_mean` over {glue:text}`ch06_r_pairs` pairs of rows, and
# {glue:text}`ch06_r_icrt` over the {glue:text}`ch06_r_icrt_pairs` pairs of ICRT rows ("n/a":
# no two rows have results at 3 seed indices or more).
# :::

# %% [markdown]
# **Codebook use of the VQ-family rows**, per training seed: the distinct codes each trained
# tokenizer gives the held-out trajectories of Table III (chapter 8), of its K, and the
# perplexity of their distribution (how many equally used codes would give it).

# %% tags=["hide-cell"]
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

# %% tags=["hide-cell"]
from icil_paper.paper.prompt_ablation import prompt_beside_baselines

display(prompt_beside_baselines(results, load_table(preset, "prompt")))

# %% [markdown]
# ## How smoothly the robot moves
#
# :::{dropdown} What LDLJ, SPARC and action jerk measure (click to open)
# The paper measures smoothness in the tokenizer's latent space (Table III); the rollouts
# also say how smoothly the arm itself moved. Every episode's end-effector path is scored
# by its log dimensionless jerk (LDLJ) and the spectral arc length of its speed profile
# (SPARC), both higher for smoother motion (a minimum-jerk reach scores -6.6 and -1.4),
# and its executed commands by their mean squared second difference (action jerk, lower
# for smoother commands); `icil_paper.metrics` gives the formulas and their sources. Each
# number is the mean over the row's seeds of each seed's mean over its episodes, with the
# seed as the unit as for success, with its 95% interval. Where some episodes lack a
# measure (an episode of a few steps, or one where the arm did not move, has none), a
# table under the frame counts the episodes that have it.
# :::

# %% tags=["hide-cell"]
show_motion(results, "avg")

# %% [markdown]
# ## By skill family
#
# Point values per family (the intervals of single families are wide at these episode
# counts); the paper's row first.

# %% tags=["hide-cell"]
show_values(results)

# %% [markdown]
# ## Which claims held
#
# Generated from the claims ledger ({doc}`chapter 0 <00_claims_ledger>`): each claim is a difference of two rows on
# the same episodes, with its paired 95% interval.

# %% tags=["hide-input"]
display(Markdown(verdicts(preset, "I")))

# %% tags=["hide-cell"]
display(claims_figure(preset, "I"))
