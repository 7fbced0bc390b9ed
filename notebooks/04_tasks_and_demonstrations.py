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

import pandas as pd
from IPython.display import Markdown, display

from icil_paper.book.components import (
    data_tasks,
    demo_stats,
    demo_summary,
    demonstration_findings,
    demos_figure,
    first_frames_figure,
    keep_rates,
    load_data_sets,
    no_expert_measurement,
    setup_lines,
    show_demo_summary,
    showcase_frame,
    showcase_recordings,
    task_registry,
    zero_shot_lines,
)
from icil_paper.book.display import show_frame_or
from icil_paper.book.studies import (
    demo_stage,
    expert_measurements,
    showcase_study,
    shown_tasks,
)
from icil_paper.config import get_preset
from icil_paper.results import ResultsStore
from icil_paper.seeding import seed_everything
from icil_paper.viz.viewer import show_recordings

preset = get_preset()  # reads ICIL_PRESET
seed_everything(preset.seed)
store = ResultsStore(preset.name)
SHOWN_TASKS = shown_tasks(preset)  # the smoke preset shows one task per suite, others all
DATA_TASKS = data_tasks()  # the data sets examined in full: one kitchen, one ManiSkill task
print(setup_lines(preset.name, SHOWN_TASKS, DATA_TASKS, preset.data.demos_per_task))

# %% [markdown]
# ## The task registry
#
# One name per task; `make_env(name)` and `make_expert(name)` are all a training or evaluation
# loop needs. Observation widths are shared within a suite (object states zero-padded).
#
# A kitchen task succeeds as its scene says (`icil_paper.sim.kitchen.scenes`): a fixture's
# joint past its goal for doors, drawers, levers, knobs and the button; the peg 2 cm deep in
# the hole for insertion; for pick-and-place, the box inside the bin, let go, and the hand at
# least 6 cm from it. RoboCasa's pick-and-place tasks likewise ask the gripper to be far
# from the object; without that, a demonstration would end the moment the gripper opens, and
# a policy would see almost no example of letting go. The expert lets the box go anywhere
# between the bin's rim and its floor (drawn per scene), so the release is shown over the
# bin's whole depth.

# %%
display(task_registry())

# %% [markdown]
# ## Run or load: a frame and a recorded demonstration of every task
#
# For each task: build the env, render its first scene, run demo 0 of the `generated` source
# and record it (rerun `.rrd` file plus a static picture). Results are cached in the results
# store; a rebuild only reads them.

# %%
showcase = showcase_study(preset, store)  # runs what is missing, else loads
display(showcase_frame(showcase))

# %%
display(first_frames_figure(showcase))

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
kept = keep_rates(data_sets, preset.data.demos_per_task)
display(kept)
experts = pd.DataFrame(expert_measurements(preset, store))  # this preset's, else results/experts/
show_frame_or(experts, no_expert_measurement(preset.name))

# %% [markdown]
# ## Run or load: the two demonstration sources
#
# The data sets were made above by `demo_stage` (`ensure_many`: one pool of worker processes
# for every data set, generating in parallel and resumably only what the files lack); training
# uses the same files. Here, one kitchen and one ManiSkill task in detail.

# %%
demos = load_data_sets(data_sets, DATA_TASKS, preset.data.demos_per_task)
stats = demo_stats(demos)  # one row per demonstration
summary = demo_summary(demos, stats)  # by task and source
show_demo_summary(summary)

# %%
display(demos_figure(demos, stats, DATA_TASKS))

# %% [markdown]
# ## Recordings
#
# Every shown task's demo 0 is recorded (actions, end-effector path, object position on a
# step timeline) and shown in the embedded rerun viewer: pick a task from its menu. Each
# recording is linked for download (`rerun <file>` opens it in the desktop viewer); the
# static picture shows where the viewer cannot start.

# %% tags=["hide-input"]
display(show_recordings(showcase_recordings(showcase)))

# %% [markdown]
# ## Generalization settings
#
# The zero-shot setting trains on some kitchen tasks and evaluates on the held-out rest; the
# sim-to-real stand-in trains on the Panda kitchen tasks and evaluates the same skills on the
# perturbed Kinova arm.

# %%
print(zero_shot_lines())

# %% [markdown]
# ## What we found

# %%
display(Markdown(demonstration_findings(showcase, kept, experts, summary, DATA_TASKS,
                                        preset.name)))
