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
from icil_paper.config import field_docs, get_preset
from icil_paper.setup.envcheck import environment_report, format_report

preset = get_preset()  # reads ICIL_PRESET; `make reproduce` sets it from PRESET (default small)

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
import dataclasses

import pandas as pd


def leaves(config, path):
    """(path, value, docstring) of every leaf field of a config, nested ones expanded."""
    docs = field_docs(type(config))
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if dataclasses.is_dataclass(value):
            yield from leaves(value, f"{path}.{f.name}")
        else:
            yield f"{path}.{f.name}", value, docs.get(f.name, "")


rows = [{"field": name, "value": str(value), "meaning": doc}
        for section in ("data", "train", "eval", "tables", "tokenizer_study")
        for name, value, doc in leaves(getattr(preset, section), section)]
rows += [{"field": name, "value": str(value), "meaning": doc}
         for name, value, doc in leaves(preset.policies.icrt, "policies.icrt")]
rows += [{"field": name, "value": str(value), "meaning": doc}
         for name, value, doc in leaves(preset.tokenizers.lipvq, "tokenizers.lipvq")]
pd.set_option("display.max_colwidth", 90)
pd.DataFrame(rows).set_index("field")

# %% [markdown]
# ## What works here

# %%
failed = [c for c in report["checks"] if not c["ok"]]
device = (report.get("torch") or {}).get("device", "cpu")
print(f"Preset {preset.name!r}, seed {preset.seed}, training on {device}.")
for c in report["checks"]:
    print(("works:  " if c["ok"] else "FAILED: ") + f"{c['name']} ({c['detail']})")
if failed:
    print("\nChapters that need a failed capability skip those experiments and say so.")
