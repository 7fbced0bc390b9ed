# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # 11. Is it smoothness? The Lipschitz bound, the latent scale and codebook collapse
#
# **The paper's explanation.** LipVQ-VAE works because Eq. 4 bounds each encoder layer's
# infinity-norm Lipschitz constant by $\mathrm{softplus}(c_\ell)$, so the encoder is
# Lipschitz with constant at most $\prod_\ell \mathrm{softplus}(c_\ell)$ (Eq. 3):
# neighbouring actions map to neighbouring latents, latent trajectories become smoother
# (Table III), and smoother action tokens make in-context imitation succeed more (Fig. 1).
#
# **Three reasons to doubt it at our scale**, each checked below:
#
# 1. *The bound may not bind.* Liu et al.'s initialisation sets each $c_\ell$ to its
#    layer's largest absolute row sum, so nothing is rescaled at the start, and the loss
#    weight $\gamma = 10^{-6}$ on the product of bounds barely moves them. If almost no row
#    is capped after training, Eq. 4 is not what makes LipVQ-VAE differ from VQ-VAE.
# 2. *Least energy measures scale as well as shape.* It grows with the square of the latent
#    scale; a bounded encoder has smaller latents, so a lower raw score can be scale. The
#    standardized least energy (latents divided by their standard deviation $\sigma$ over
#    the held-out set) removes that.
# 3. *A collapsed codebook is trivially smooth.* A trajectory that stays on one code has
#    zero least energy whatever the encoder does.
#
# **The cells.** ICRT on the kitchen suite (Table I's setting) with VQ-VAE and LipVQ-VAE as
# Table I trains them, and variants: a Lipschitz loss weight $\gamma = 1$ and initial
# bounds $c_\ell = 1$ (both make Eq. 4 bind), dead-code restarts (every 100 training steps
# unused codes jump to random encoder outputs: a standard remedy for collapse), and ICRT
# trained on whole episodes from step 0, the window it acts with (ICRT trains on 32-step
# query windows that start anywhere, but acts from step 0 of an episode). Every variant
# trains the preset's number of ICRT seeds (stated below for each source). For each: success
# over the kitchen tasks, raw and standardized least energy of its own tokenizer's latent
# features on held-out trajectories (as in Table III), $\sigma$, the codes used, the share
# of encoder rows Eq. 4 caps, the product of the bounds and an empirical Lipschitz constant
# (largest ratio of output to input change over nearby held-out actions, infinity norm).

# %% tags=["hide-input"]
from IPython.display import Markdown, display

from icil_paper.config import get_preset
from icil_paper.tables.analysis import analysis_frame, conclusion, findings
from icil_paper.tables.book import design_sentence, load_table, show_per_source, source_label

preset = get_preset()
results = load_table(preset, "analysis")

# %% tags=["hide-input"]
show_per_source(results, analysis_frame,
                describe=lambda result: design_sentence(get_preset(result.preset)))

# %% [markdown]
# ## The comparisons
#
# Each line is one comparison on the same episodes (success) or the same held-out
# trajectories (least energy), with its paired 95% interval and the verdict on the
# direction the smoothness explanation predicts (LipVQ-VAE and the binding variants
# smoother and more successful).

# %% tags=["hide-input"]
for source, result in results.items():
    lines = [f"**{source_label(source, result.preset)}**", ""]
    for f in findings(result):
        est = f["estimate"]
        value = ("not run" if est is None else
                 f"{est.value:+.3f} [{est.low:+.3f}, {est.high:+.3f}]")
        expected = "below 0" if f["direction"] < 0 else "above 0"
        lines.append(f"- {f['quantity']}: {value} (expected {expected}): {f['verdict']}")
    display(Markdown("\n".join(lines)))

# %% [markdown]
# ## Verdict

# %% tags=["hide-input"]
for source, result in results.items():
    display(Markdown(f"**{source_label(source, result.preset)}.** {conclusion(result)}"))
