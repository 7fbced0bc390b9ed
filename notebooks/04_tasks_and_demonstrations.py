# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # 4. Tasks and demonstrations
#
# **What the paper uses.** Its simulation results come from two suites. On RoboCasa it
# evaluates seven foundational skill families (pick and place, doors, drawers, levers, knobs,
# insertion, buttons), trains on MimicGen-generated demonstrations, and for its cross-dataset
# table moves to RoboCasa's human teleoperation data; its zero-shot table holds some tasks out
# of training, and its sim-to-real table uses a Kinova Gen3 arm. On ManiSkill 3 it evaluates
# Pick Cube, Push Cube and Stack Cube with demonstrations from ManiSkill's motion planners.
#
# **What we build instead.** None of RoboCasa's kitchens, assets or data sets, nor MimicGen's,
# can be downloaded here, so the `kitchen/...` tasks rebuild the seven skill families on
# robosuite with fixtures made in code, the `kinova/...` tasks put the door and drawer tasks
# on robosuite's Kinova3 arm with perturbed dynamics and noisy observations (our sim-to-real
# stand-in), and the `maniskill/...` tasks are ManiSkill 3's own. Every task has a scripted
# expert; the data sets have two sources:
#
# - `generated`: the expert on randomized scenes, our stand-in for MimicGen data;
# - `human`: the same expert driven through a model of a teleoperating person (correlated
#   hand noise, hesitations, drifting speed, overshoots that get corrected).
#
# All tasks share one 7-D action (end-effector position and axis-angle deltas, gripper) and,
# within a suite, one observation layout. This chapter shows every task, the experts' success
# rates, and how the two sources' demonstrations differ.

# %% tags=["hide-input"]
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # offscreen rendering on CPU (set before robosuite)

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import display

from icil_paper import sim
from icil_paper.book.studies import (
    demo_stage,
    expert_measurements,
    showcase_study,
    shown_tasks,
)
from icil_paper.book.summaries import demonstration_findings
from icil_paper.config import get_preset
from icil_paper.data import SOURCES, load_demos, zero_shot_split
from icil_paper.data.stats import data_set_stats, keep_rate
from icil_paper.results import ResultsStore
from icil_paper.seeding import seed_everything
from icil_paper.viz.viewer import show_recordings

preset = get_preset()  # reads ICIL_PRESET
seed_everything(preset.seed)
store = ResultsStore(preset.name)
# the smoke preset shows one task per suite; the others show every task
SHOWN_TASKS = shown_tasks(preset)
# the data sets examined in full: one kitchen and one ManiSkill task, both sources
DATA_TASKS = [t for t in ("kitchen/open_drawer", "maniskill/pick_cube") if t in sim.all_tasks()]
print(f"preset {preset.name}: {len(SHOWN_TASKS)} tasks shown, data sets of {DATA_TASKS} with "
      f"{preset.data.demos_per_task} demos per source")
unavailable = {s: sim.suite_unavailable(s) for s in sim.SUITES if sim.suite_unavailable(s)}
if unavailable:
    print("suites that cannot run here:", unavailable)

# %% [markdown]
# ## The task registry
#
# One name per task; `make_env(name)` and `make_expert(name)` are all a training or evaluation
# loop needs. Observation widths are shared within a suite (object states zero-padded).

# %%
registry = pd.DataFrame([{"task": t, "suite": sim.suite_of(t),
                          "proprio, object": sim.obs_dims(sim.suite_of(t))}
                         for t in sim.all_tasks()])
display(registry)

# %% [markdown]
# ## Run or load: a frame and a recorded demonstration of every task
#
# For each task: build the env, render its first scene, run demo 0 of the `generated` source
# and record it (rerun `.rrd` file plus a static picture). Results are cached in the results
# store; a rebuild only reads them.

# %%
showcase = showcase_study(preset, store)  # runs what is missing, else loads
shown = pd.DataFrame(showcase.values())[["task", "instruction", "success", "length", "horizon",
                                         "seconds"]]
display(shown)

# %%
cols = 6
rows = int(np.ceil(len(showcase) / cols))
fig, axes = plt.subplots(rows, cols, figsize=(2.6 * cols, 2.8 * rows), squeeze=False)
for ax in axes.flat:
    ax.axis("off")
for ax, (task, entry) in zip(axes.flat, showcase.items(), strict=False):
    ax.imshow(plt.imread(entry["frame"]))
    ax.set_title(task, fontsize=8)
fig.suptitle("first scene of every task (seed of demo 0)")
plt.tight_layout()
plt.show()

# %% [markdown]
# ## Expert success rates
#
# Each expert must succeed on at least 90% of 50 random scenes. Two measurements:
#
# - **over the data sets' scenes** (every preset): a data set keeps only successful episodes
#   and records how many attempts each demo took, so the share of attempts kept is the
#   expert's (or the human source's) success rate over the scenes it was generated on;
# - **over `data.expert_seeds` fresh scenes** (the `experts` stage; 50 under the full preset):
#   success, an open-loop replay of the stored actions, the human source's keep rate (on the
#   scenes it is generated on), and, for the kitchen suite, the expert's success on the
#   `human` scene distribution of Table VI.
#   Any preset can run it by hand: `python -m icil_paper.data.experts --suites <suite>
#   --seeds 50` writes `results/experts/<suite>.json`, which this chapter also reads.

# %%
data_sets = demo_stage(preset, store)  # every task, both sources (cheap once they exist)
kept = []
for (task, source), path in data_sets.items():
    ds = load_demos(path, action_dim=7, limit=preset.data.demos_per_task, images=False)
    kept.append({"task": task, "source": source, "demos": len(ds), "keep rate": keep_rate(ds)})
kept = pd.DataFrame(kept).pivot(index="task", columns="source", values="keep rate")
kept.columns = [f"{c}: success over data-set scenes" for c in kept.columns]
display(kept)

expert_rows = expert_measurements(preset, store)  # this preset's, else results/experts/
experts = pd.DataFrame(expert_rows)
if expert_rows:
    display(experts)
else:
    print(f"no fresh-scene measurement under the {preset.name} preset (data.expert_seeds = 0); "
          "see the command above")

# %% [markdown]
# ## Run or load: the two demonstration sources
#
# The data sets were made above by `demo_stage` (`ensure_many`: one pool of worker processes
# for every data set, generating in parallel and resumably only what the files lack); training
# uses the same files. Here, one kitchen and one ManiSkill task in detail.

# %%
demos = {(task, source): load_demos(data_sets[task, source], action_dim=7,
                                    limit=preset.data.demos_per_task, images=False)
         for task in DATA_TASKS for source in SOURCES}
stats = pd.DataFrame([row for ds in demos.values() for row in data_set_stats(ds)])
summary = stats.groupby(["task", "source"]).agg(
    demos=("length", "size"), mean_length=("length", "mean"), std_length=("length", "std"),
    least_energy_per_step=("least_energy_per_step", "mean"),
    still_fraction=("still_fraction", "mean"),
    gripper_switches=("gripper_switches", "mean"))
summary["keep_rate"] = [keep_rate(demos[key]) for key in summary.index]
short = {"mean_length": "mean length", "std_length": "std", "least_energy_per_step":
         "least energy / step", "still_fraction": "still", "gripper_switches": "gripper switches",
         "keep_rate": "kept"}  # short headers, so that the table fits the page
with pd.option_context("display.float_format", "{:.3g}".format):
    display(summary.rename(columns=short))

# %%
fig, axes = plt.subplots(1, 1 + len(DATA_TASKS), figsize=(5 * (1 + len(DATA_TASKS)), 3.4))
bins = np.linspace(stats.length.min(), stats.length.max() + 1, 13)
for source, color in zip(SOURCES, ("tab:blue", "tab:orange"), strict=True):
    axes[0].hist(stats[stats.source == source].length, bins=bins, color=color, alpha=0.6,
                 label=source)
axes[0].set(xlabel="demo length [steps]", ylabel="demos",
            title=f"demo lengths ({', '.join(t.split('/')[1] for t in DATA_TASKS)})")
axes[0].legend(fontsize=8)
for ax, task in zip(axes[1:], DATA_TASKS, strict=True):
    for source, color in zip(SOURCES, ("tab:blue", "tab:orange"), strict=True):
        demo = demos[task, source][0]
        ax.plot(demo.actions[:, 0], color=color, label=f"{source} dx")
        ax.plot(demo.actions[:, 2], color=color, ls="--", label=f"{source} dz")
    ax.set(xlabel="step", ylabel="action", title=f"{task}: demo 0 of each source")
    ax.legend(fontsize=7)
plt.tight_layout()
plt.show()

# %% [markdown]
# ## Recordings
#
# Every shown task's demo 0 is recorded (actions, end-effector path, object position on a
# step timeline) and shown in the embedded rerun viewer: pick a task from its menu. Each
# recording is linked for download (`rerun <file>` opens it in the desktop viewer); the
# static picture shows where the viewer cannot start.

# %% tags=["hide-input"]
display(show_recordings({task: (entry["rrd"], entry["picture"])
                         for task, entry in showcase.items()}))

# %% [markdown]
# ## Generalization settings
#
# The zero-shot setting trains on some kitchen tasks and evaluates on the held-out rest; the
# sim-to-real stand-in trains on the Panda kitchen tasks and evaluates the same skills on the
# perturbed Kinova arm.

# %%
try:
    train_tasks, held_out = zero_shot_split()
    print("zero-shot: train on", list(train_tasks))
    print("           hold out", list(held_out))
except ImportError as exc:
    print("kitchen suite unavailable:", exc)

# %% [markdown]
# ## What we found

# %%
print(demonstration_findings(showcase, kept, experts, summary, DATA_TASKS, preset.name))
