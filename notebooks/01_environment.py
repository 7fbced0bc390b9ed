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
# package versions that every result records, the hardware, whether the two simulators
# (robosuite for our kitchen tasks, ManiSkill 3 for the paper's ManiSkill table) start and
# step, whether offscreen rendering works for image observations, and which preset is
# active. Every check below runs in a separate process, so a failing native library shows
# up as a failed row with the fix to apply instead of stopping the book.

# %% tags=["hide-input"]
import pandas as pd

from icil_paper.book.environment import capabilities, preset_fields
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

# %%
print(capabilities(report, preset))
