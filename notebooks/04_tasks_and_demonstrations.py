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
# can be downloaded here. The paper's RoboCasa tables run on **Meta-World** (metaworld
# 3.1.1), a public benchmark of 50 tabletop tasks for a Sawyer arm in MuJoCo, with a scripted
# expert for every task. Thirteen of its tasks, `metaworld/<task>`, stand in for the seven
# skill families:
#
# | RoboCasa family | Meta-World tasks |
# |---|---|
# | Pick and Place | pick-place, pick-place-wall |
# | Open/Close Doors | door-open, door-close |
# | Open/Close Drawers | drawer-open, drawer-close |
# | Turning Levers | faucet-open, faucet-close (RoboCasa's levers are sink faucets) |
# | Twisting Knobs | dial-turn |
# | Insertion | peg-insert-side, coffee-push (RoboCasa's insertion puts a mug under the coffee machine) |
# | Pressing Buttons | button-press, coffee-button |
#
# - *Observations.* Meta-World's 39-number state, split as in every suite here: `proprio`
#   (8) is the hand's position and the gripper's opening, now and one step before; `object`
#   (31) is the poses of up to two objects, now and one step before (zeros for a missing
#   second object), and the goal's position. The goal is always observed: many of
#   Meta-World's scripted experts read their target from it.
# - *Actions.* The project's 7-D action maps to Meta-World's [dx, dy, dz, gripper], 1 cm of
#   hand motion per unit and step. Meta-World's gripper always points down, so the three
#   rotation entries are ignored, and the demonstrations carry zeros there.
# - *Layouts.* Each episode's seed draws its layout (object, goal and fixture positions)
#   from the task's range, so a seed is a layout; training demonstrations, prompts and
#   evaluation episodes use disjoint seeds, so a policy is always evaluated on layouts it has
#   not seen.
# - *Two scene distributions.* `generated` is Meta-World's own range. `human`, Table VI's
#   shift, starts the hand up to 5 cm from its usual place on each axis and draws every
#   object and goal coordinate from the outer 40% of its range (a fifth at each end).
# - *Experts.* Meta-World's scripted policy of each task, its action clipped to [-1, 1]:
#   the clipped action is what the env executes and what the data sets store.
# - *Zero-shot.* Table VII uses Meta-World's own ML45 split: 45 training tasks (the 13 above
#   among them) and five held out, bin-picking, box-close, hand-insert, door-lock and
#   door-unlock.
#
# The robosuite kitchen suite (`kitchen/...`: 11 tasks on a Panda arm, with fixtures built as
# MJCF in the library) stood in for RoboCasa in earlier versions of this book. It keeps one
# role: Table V's policies train on its door and drawer tasks (`kitchen/open_door`,
# `close_door`, `open_drawer`, `close_drawer`), and the `kinova/...` tasks are their twins
# on robosuite's Kinova3 arm with perturbed fixture dynamics and noisy observations (our
# sim-to-real stand-in). The `maniskill/...` tasks are ManiSkill 3's own. Every task has a
# scripted expert, and the data sets have two sources:
#
# - `generated`: the expert on seeded layouts, our stand-in for MimicGen data;
# - `human`: the same expert driven through a model of a teleoperating person (correlated
#   hand noise, hesitations, changing speed, overshoots that get corrected), played on the
#   suite's `human` scenes where it has them (Meta-World's and the kitchen suite's), our
#   stand-in for RoboCasa's human data set.
#
# Every policy trains on plenty of demonstrations per task, as the paper's do on MimicGen
# data: the count is the preset's `data.demos_per_task`, which the reference preset takes
# from a data curve in the pilot of {doc}`chapter 6 <06_table1_kitchen>` (the count where
# more demonstrations no longer raise BC-Transformer's success).
#
# All tasks share one 7-D action (end-effector position and axis-angle deltas, gripper) and,
# within a suite, one observation layout. This chapter shows every task a table evaluates on,
# the experts' success rates, and how the two sources' demonstrations differ.

# %% tags=["hide-input"]
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # offscreen rendering on CPU (set before MuJoCo loads)

import pandas as pd
from IPython.display import display

from icil_paper import sim
from icil_paper.book.components import (
    data_tasks,
    demo_stats,
    demo_summary,
    demos_figure,
    first_frames_figure,
    keep_rates,
    load_data_sets,
    show_demo_summary,
    showcase_frame,
    showcase_recordings,
    task_registry,
    zero_shot_lines,
)
from icil_paper.book.studies import (
    demo_stage,
    expert_measurements,
    showcase_study,
    shown_tasks,
)
from icil_paper.config import get_preset
from icil_paper.results import ResultsStore
from icil_paper.seeding import seed_everything
from icil_paper.tables.display import show_frame_or
from icil_paper.viz.viewer import show_recordings

preset = get_preset()  # reads ICIL_PRESET
seed_everything(preset.seed)
store = ResultsStore(preset.name)
SHOWN_TASKS = shown_tasks(preset)  # smoke: one task per suite; others: every evaluated task
DATA_TASKS = data_tasks()  # the data sets examined in full: one Meta-World, one ManiSkill task
print(f"{len(SHOWN_TASKS)} tasks shown; data sets examined in full: {list(DATA_TASKS)}")
print({s: sim.suite_unavailable(s) for s in sim.SUITES if sim.suite_unavailable(s)} or "")

# %% [markdown]
# ## The task registry
#
# One name per task; `make_env(name)` and `make_expert(name)` are all a training or evaluation
# loop needs. Observation widths are shared within a suite (object states zero-padded). The
# registry lists all 50 Meta-World tasks (Table VII trains on 45 of them), and the kitchen
# suite's 11, of which Table V uses the four door and drawer tasks.
#
# A Meta-World task succeeds as Meta-World says (`info["success"]`, the benchmark's own
# test, e.g. drawer-open's handle within 3 cm of its open position, pick-place's puck within
# 7 cm of its goal); an episode ends at its first successful step, or is cut at the task's
# horizon (200 control steps at 80 Hz; Meta-World's own limit of 500 steps is not used).
# A kitchen or Kinova door or drawer task succeeds when the fixture's joint is past its goal
# (`icil_paper.sim.kitchen.scenes`); a ManiSkill task by ManiSkill's own test.

# %% tags=["hide-output"]
display(task_registry())

# %% [markdown]
# ## Run or load: a frame and a recorded demonstration of every evaluated task
#
# For each task a table evaluates on (the 13 Meta-World tasks of Table I, the five held out
# by ML45, the Panda and Kinova door and drawer tasks, ManiSkill's three; not the 32 tasks
# that only Table VII trains on): build the env, render its first scene, run demo 0 of the
# `generated` source and record it (rerun `.rrd` file plus a static picture). Results are
# cached in the results store; a rebuild only reads them.

# %% tags=["hide-cell"]
showcase = showcase_study(preset, store)  # runs what is missing, else loads
display(showcase_frame(showcase))

# %% tags=["hide-cell"]
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
#   scenes it is generated on), and, where the suite has a `human` scene distribution
#   (Meta-World's is Table VI's shift), the expert's success on those scenes too.
#   Any preset can run it by hand: `python -m icil_paper.data.experts --suites <suite>
#   --seeds 50` writes `results/experts/<suite>.json`, which this chapter also reads.

# %% tags=["hide-output"]
data_sets = demo_stage(preset, store)  # both sources (Table VII's training tasks: generated); cheap once made
kept = keep_rates(data_sets, preset.data.demos_per_task)
display(kept)
experts = pd.DataFrame(expert_measurements(preset, store))  # this preset's, else results/experts/
show_frame_or(experts, "No fresh-scene measurement in this preset (`data.expert_seeds` = 0).")

# %% [markdown]
# ## Run or load: the two demonstration sources
#
# The data sets were made above by `demo_stage` (`ensure_many`: one pool of worker processes
# for every data set, generating in parallel and resumably only what the files lack); training
# uses the same files. Here, one Meta-World task (`metaworld/drawer-open`) and one ManiSkill
# task (`maniskill/pick_cube`) in detail.

# %% tags=["hide-output"]
demos = load_data_sets(data_sets, DATA_TASKS, preset.data.demos_per_task)
stats = demo_stats(demos)  # one row per demonstration
summary = demo_summary(demos, stats)  # by task and source
show_demo_summary(summary)

# %% tags=["hide-output"]
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
# The zero-shot setting (Table VII) trains on Meta-World's ML45 training tasks and evaluates
# on its five held-out tasks; the sim-to-real stand-in (Table V) trains on the Panda
# kitchen's door and drawer tasks and evaluates the same skills on the perturbed Kinova3
# arm.

# %% tags=["hide-output"]
print(zero_shot_lines())

# %% [markdown]
# ## What we found

# %% tags=["remove-cell"]
from myst_nb import glue

from icil_paper.book.components import EXPERT_REQUIREMENT, KEPT_COLUMN

failed = [t for t, e in showcase.items() if not e["success"]]
glue("ch04_shown", len(showcase))
glue("ch04_shown_ok", len(showcase) - len(failed))
generated_rate = kept[KEPT_COLUMN.format(source="generated")]
glue("ch04_kept_low", float(generated_rate.min()))
glue("ch04_kept_high", float(generated_rate.max()))
glue("ch04_below", ", ".join(generated_rate[generated_rate < EXPERT_REQUIREMENT].index) or "none")
glue("ch04_requirement", EXPERT_REQUIREMENT)
for column in ("mean_length", "least_energy_per_step"):
    ratio = [summary.loc[(t, "human"), column] / max(summary.loc[(t, "generated"), column], 1e-12)
             for t in DATA_TASKS]
    glue(f"ch04_{column}_low", float(min(ratio)))
    glue(f"ch04_{column}_high", float(max(ratio)))

# %% [markdown]
# **The experts.** Demonstration 0 of the generated source succeeded on
# {glue:text}`ch04_shown_ok` of the {glue:text}`ch04_shown` tasks shown. Over the scenes the
# data sets were generated on, the experts succeeded in {glue:text}`ch04_kept_low:.0%` to
# {glue:text}`ch04_kept_high:.0%` of attempts per task; tasks below the
# {glue:text}`ch04_requirement:.0%` the paper's data need: {glue:text}`ch04_below`. The
# table of experts above has their success over fresh scenes, where it was measured.
#
# **Human against generated demonstrations.** Across the data sets examined in full, the
# human source's demonstrations are {glue:text}`ch04_mean_length_low:.2f` to
# {glue:text}`ch04_mean_length_high:.2f` times as long as the generated ones, and their least
# energy per step is {glue:text}`ch04_least_energy_per_step_low:.3g` to {glue:text}`ch04_least_energy_per_step_high:.3g`
# times theirs: above 1, they are less smooth, as a human-like source is meant to be.
