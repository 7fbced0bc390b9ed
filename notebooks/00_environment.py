# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # 0. Your environment
#
# Before anything is trained, this chapter checks the machine the book is built on: the
# package versions that every result records, the hardware, whether the two simulators
# (robosuite for our kitchen tasks, ManiSkill 3 for the paper's ManiSkill table) start and
# step, whether offscreen rendering works for image observations, and which preset is
# active. Every check below runs in a separate process, so a failing native library shows
# up as a failed row with the fix to apply instead of stopping the book.

# %%
from icil_paper.config import field_docs, get_preset
from icil_paper.envcheck import environment_report, format_report

preset = get_preset()  # reads ICIL_PRESET; `make reproduce` sets it from PRESET (default small)

# %%
report = environment_report()
print(format_report(report))

# %% [markdown]
# ## The active preset
#
# Every run stores this whole configuration with its result, together with its seed, the
# git commit and the package versions above. The table lists the fields that differ most
# between presets.

# %%
import pandas as pd

rows = []
for section in ("data", "tokenizer", "policy", "train", "eval"):
    config = getattr(preset, section)
    docs = field_docs(type(config))
    for field, value in vars(config).items():
        rows.append({"section": section, "field": field, "value": str(value),
                     "meaning": docs.get(field, "")})
pd.set_option("display.max_colwidth", 90)
pd.DataFrame(rows)

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
