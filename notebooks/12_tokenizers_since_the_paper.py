# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # 12. Tokenizers since the paper: FSQ, residual VQ and B-splines, with and without Eq. 4
#
# **The question.** The paper compares its LipVQ-VAE with the action tokenizers of its
# time. The field has since moved to others: finite scalar quantization (FSQ, Mentzer et
# al. 2023; used by QueST and OAT), residual vector quantization (VQ-BeT's tokenizer) and
# B-spline control points (BEAST, Zhou et al. 2025; OmniSAT combines B-splines with residual
# VQ). None of the paper, its official code, ICRT or LeRobot compares them inside
# in-context imitation, and none asks the follow-up question the paper invites: does
# Eq. 4's Lipschitz normalisation help every quantizer, or only VQ? This table is our own;
# the paper has no numbers for it beyond its Table I's VQ-VAE and LipVQ-VAE rows.
#
# **How it is computed here.** Table I's protocol ({doc}`chapter 6 <06_table1_kitchen>`):
# one ICRT policy per row, trained on the generated demonstrations of Table I's 13
# Meta-World tasks and evaluated per task on the same episodes as every other row, so rows are compared
# episode by episode. The VQ-VAE and LipVQ-VAE rows are Table I's policies (the same run
# specs, trained once); the reference run trains five seeds for every row, two more than
# Table I's. `lipfsq` and `liprvq` are FSQ and residual VQ with every encoder layer a
# `LipschitzLinear` and the $10^{-6}\prod_\ell \mathrm{softplus}(c_\ell)$ term of Eq. 5,
# exactly as LipVQ-VAE is VQ-VAE with them ({doc}`chapter 5 <05_action_tokenizers>`
# describes each tokenizer and measures it trained alone). The `features` columns are the
# trained policies' own tokenizers on held-out trajectories, as in Table III
# ({doc}`chapter 8 <08_smoothness>`) and the analysis table
# ({doc}`chapter 11 <11_is_it_smoothness>`).
#
# The tables show **the paper** (Table I's two rows), **our run** (the `reference` preset,
# results committed under `results/reference/`)
# and **the quick run** (CI's small preset: it tests the code, not the
# paper).

# %% tags=["hide-input"]
from IPython.display import Markdown, display

from icil_paper.book.experiments import eq4_differences
from icil_paper.book.report import claims_figure, load_table, verdicts
from icil_paper.config import get_preset
from icil_paper.paper.analysis import analysis_frame
from icil_paper.tables.display import (
                       show_comparison,
                       show_motion,
                       show_per_source,
                       show_values,
                       success_figure,
)

preset = get_preset()  # reads ICIL_PRESET
results = load_table(preset, "beyond")  # computes what this build's results store lacks

# %% [markdown]
# ## Average success over the Meta-World tasks

# %% tags=["hide-input"]
show_comparison(results, "avg")
display(success_figure(results, "avg",
                       title="Tokenizers since the paper: average success over the Meta-World tasks"))

# %% [markdown]
# ## By skill family
#
# Point values per family (the intervals of single families are wide at these episode
# counts); `features` is the raw least energy of the latent features.

# %% tags=["hide-input"]
show_values(results)

# %% [markdown]
# ## Latent features and Eq. 4
#
# Success with its interval, then each trained tokenizer's raw and standardized least
# energy (the standardized one divides the latents by their standard deviation $\sigma$,
# so that a small latent does not pass for a smooth one), $\sigma$, the codes used on the
# held-out trajectories, and, for the `lip*` rows, the share of encoder rows Eq. 4 caps,
# the product of the bounds and an empirical Lipschitz constant (means over seeds).

# %% tags=["hide-input"]
show_per_source(results, analysis_frame)

# %% [markdown]
# ## Smoothness of the motion
#
# Success beside the smoothness of the motion that earned it, as in Table I's chapter: the
# log dimensionless jerk (LDLJ) and the spectral arc length (SPARC) of the end-effector's
# path (both higher for smoother motion) and the mean squared second difference of the
# executed actions (action jerk, lower for smoother commands); `icil_paper.metrics` gives
# the formulas and their sources. The seed is the unit, as for success.

# %% tags=["hide-input"]
show_motion(results, "avg")

# %% [markdown]
# ## Does Eq. 4 help every quantizer?
#
# Each line is one row minus another on the same episodes, with its paired 95% interval
# and the verdict on "the Eq. 4 variant succeeds more"; then the claims ledger's sentences
# about this table ({doc}`chapter 0 <00_claims_ledger>`), where it holds claims about it.

# %% tags=["hide-input"]
display(Markdown(eq4_differences(results)))
display(Markdown(verdicts(preset, "beyond")))
display(claims_figure(preset, "beyond"))
