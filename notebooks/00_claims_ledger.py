# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # 0. Which claims held: the claims ledger
#
# Every claim the paper makes in its experiments (Sec. IV), checked against our numbers.
# Each claim is written as a quantity with a direction: "LipVQ-VAE beats BC-Transformer by
# 5.3 points" is the difference of the two rows' average success, claimed above 0. The
# paper's value of that quantity is computed from its own tables; ours from our records,
# with a 95% interval. Rows are compared on the same evaluation episodes, so a difference's
# interval comes from a paired bootstrap (`icil_paper.stats`).
#
# **The rule.** A claim *holds* when our whole interval lies on the claimed side of 0; it
# *does not hold* when the whole interval lies on the other side (we measured the
# opposite); it is *inconclusive* when the interval contains 0: our data cannot tell at
# this number of seeds and episodes, which is not evidence against the paper. *Not run*
# means a record the claim needs is missing.
#
# Two sources: the **reference run** (records committed under `results/reference/`: the
# numbers worth reading) and **this build** (the preset this book was built with; on CI the
# `small` preset, trained for a few hundred steps: it checks the code, not the paper). The
# ledger of each is written to `results/<preset>/claims.json`.
#
# The substitutions behind every table (our kitchen suite for RoboCasa, a perturbed
# simulated Kinova for the real robot, ...) are listed in the introduction; a claim that
# holds here holds for the stand-in, not for RoboCasa.

# %%
from collections import Counter

import pandas as pd
from IPython.display import Markdown, display

from icil_paper.config import get_preset
from icil_paper.results import ResultsStore
from icil_paper.tables.book import REFERENCE, ledger_frame, stale_records
from icil_paper.tables.claims import claims_ledger, write_ledger

pd.set_option("display.max_colwidth", None)  # the claims' quantities in full
preset = get_preset()
sources = [("this build", preset)]
if preset.name != REFERENCE:
    sources.insert(0, ("reference run", get_preset(REFERENCE)))

# %%
for source, p in sources:
    store = ResultsStore(p.name)
    if p.name == preset.name:
        write_ledger(p, store)
    ledger = claims_ledger(p, store)
    counts = Counter(e["verdict"] for e in ledger)
    summary = ", ".join(f"{counts[v]} {v}" for v in
                        ("holds", "does not hold", "inconclusive", "not run") if counts[v])
    display(Markdown(f"## {source} (`{p.name}` preset): {summary}"))
    display(ledger_frame(ledger))

# %% [markdown]
# ## Reference records made by older code
#
# A committed reference record whose key the current code no longer computes (a config or
# a definition changed since it was run) is not used above; it is listed here.

# %%
stale = stale_records(REFERENCE)
display(Markdown("None: every committed reference record is current." if not stale else
                 f"{len(stale)} stale record(s), not used: " + ", ".join(stale[:20])))
