# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # 9. Table IV and Fig. 5: the Lipschitz ablation and the codebook size
#
# **What the paper claims (Sec. IV-B).** Adding the Lipschitz normalisation of Eq. 4 to a
# tokenizer's encoder raises ICRT's average success by 2.3 points for the MLP tokenizer
# (0.442 to 0.465) and by 5.5 for VQ-VAE (0.475 to 0.530, LipVQ-VAE), and VQ-VAE beats MLP
# with and without it (Table IV). Sweeping LipVQ-VAE's codebook from $2^8$ to $2^{11}$
# entries, $2^{10}$ is best (0.530; Fig. 5).
#
# **How it is computed here.** Table IV's MLP, VQ-VAE and LipVQ-VAE rows are Table I's
# policies; Lip-MLP is the same MLP with every encoder layer a `LipschitzLinear` (Eq. 4)
# and the $10^{-6} \prod_l \mathrm{softplus}(c_l)$ term of Eq. 5. Fig. 5's sweep is scaled
# to the preset's model (its third size is the paper's $2^{10}$ position; the preset's
# Table I cell is one of the four), one training seed per size. Beside each VQ-family row
# stands its codebook use: the distinct codes its trained tokenizer gives the held-out
# trajectories of Table III ({doc}`chapter 8 <08_smoothness>`), of its K, and the
# perplexity of their distribution (how many equally used codes would give it), per seed.
#
# The tables show **the paper**, **our run** ({glue:text}`ch09_seeds` seeds a row,
# results committed under `results/reference/`; a row whose records
# are not there yet reads "not run") and **the quick run** (CI's small
# preset: it tests the code, not the paper; in a collapsed
# block).

# %% tags=["remove-cell"]
from myst_nb import glue

from icil_paper.book.report import committed_design

seeds = committed_design("IV")["seeds"].values() or [0]
glue("ch09_seeds", f"{min(seeds)}" if min(seeds) == max(seeds) else f"{min(seeds)} to {max(seeds)}")

# %% tags=["hide-input"]
from IPython.display import Markdown, display

from icil_paper.book.report import claims_figure, load_table, verdicts
from icil_paper.config import get_preset
from icil_paper.paper.table_iv import codes_used_frame
from icil_paper.tables.display import show_codebook_use, show_comparison, success_figure

preset = get_preset()
table4 = load_table(preset, "IV")
fig5 = load_table(preset, "fig5")

# %% [markdown]
# ## Table IV: Lipschitz regularization's impact

# %% tags=["hide-input"]
show_comparison(table4, "avg")
display(success_figure(table4, "avg", title="Table IV: with and without Eq. 4"))

# %% [markdown]
# Codebook use of Table IV's VQ-VAE and LipVQ-VAE rows, per training seed.

# %% tags=["hide-input"]
show_codebook_use(table4)

# %% tags=["hide-input"]
display(Markdown(verdicts(preset, "IV")))
display(claims_figure(preset, "IV"))

# %% [markdown]
# ## Fig. 5: codebook size
#
# The paper sweeps $2^8 \ldots 2^{11}$ with its model; the preset sweeps four sizes scaled
# to its smaller model, and each row stands beside the paper's size at the same position
# (its label names both).

# %% tags=["hide-input"]
show_comparison(fig5, "avg")
display(success_figure(fig5, "avg", title="Fig. 5: LipVQ-VAE's codebook size"))

# %% [markdown]
# How many of its codes each codebook size used on the held-out trajectories, its share of
# K and the perplexity of their distribution (means over the seeds measured, from the
# features records), then each size's codebook use per seed.

# %% tags=["hide-input"]
display(codes_used_frame(fig5))
show_codebook_use(fig5)

# %% tags=["hide-input"]
display(Markdown(verdicts(preset, "fig5")))
display(claims_figure(preset, "fig5"))
