# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # 1. Your environment
#
# Before anything is trained, this chapter checks the machine the book is built on: the
# package versions that every result records, the hardware, whether the simulators start
# and step (Meta-World for the paper's RoboCasa tables, robosuite for the Panda and Kinova3
# tasks of the sim-to-real stand-in, ManiSkill 3 for the paper's ManiSkill table), whether
# offscreen rendering works for image observations, and which preset is active. Every check
# below runs in a separate process, so a failing native library shows up as a failed row
# with the fix to apply instead of stopping the book.
#
# Meta-World and robosuite both run on MuJoCo, and they share one MuJoCo: the pinned
# mujoco 3.3.7, the version robosuite 1.5.2 is measured to work with. Meta-World
# (metaworld 3.1.1) declares mujoco 3.3.0 exactly, which nothing in its code needs, so
# `make setup` installs it with `pip install --no-deps` beside the pinned version. The same
# actions give different physics under the two MuJoCo versions, which is one reason every
# record stores the package versions it was made with: demonstrations and rollouts are
# comparable only under the same MuJoCo.

# %% tags=["hide-input"]
import pandas as pd

from icil_paper.book.report import preset_fields
from icil_paper.config import get_preset
from icil_paper.setup.envcheck import environment_report, format_report

preset = get_preset()  # reads ICIL_PRESET; `make reproduce` sets it from PRESET (default small)
pd.set_option("display.max_colwidth", 90)  # the preset's docstrings, wrapped to the page

# %%
report = environment_report(preset.name)
print(format_report(report))

# %% [markdown]
# ## The active preset
#
# Every run stores the part of this configuration it reads with its result (its run spec,
# whose content key names the result), together with its seed, the git commit and the
# package versions above. Every field below can be changed from the command line with
# `--set SECTION.FIELD=VALUE` (e.g. `--set train.steps=300`); the component sections hold
# one config per tokenizer and per policy.

# %%
preset_fields(preset)

# %% [markdown]
# ## What works here
#
# Each check of the environment report above, one row each. A chapter whose experiment needs
# a capability that failed here skips that experiment and says so.

# %%
print(f"preset {preset.name}, seed {preset.seed}")
pd.DataFrame(report["checks"]).set_index("name")[["ok", "detail"]]
