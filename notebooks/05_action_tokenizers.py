# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # 5. Action tokenizers on their own
#
# **What the paper claims (Sec. IV, Table III).** The action tokenizer decides how well
# in-context imitation works, and smoother latent trajectories go with higher success.
# Scored by the least energy of the latent trajectory (lower is smoother), the paper ranks
# LipVQ-VAE smoothest (0.63), then LFQ-VAE, VQ-VAE, FAST, MLP, and Bin last.
#
# ## The tokenizers
#
# Each turns an action trajectory $(T, 7)$ into one embedding per step, the action tokens
# the policy interleaves with its observation tokens (`icil_paper.tokenizers`, one file
# each, built from one config dataclass each):
#
# - **MLP** (ICRT's own): an MLP embeds each action; the embedding is shaped by the policy's
#   loss alone. **Lip-MLP** (Table IV) is the same MLP with every layer normalized by Eq. 4.
# - **Bin** (RT-1): each action dimension is cut into 256 equal bins over its range in the
#   training data; every (dimension, bin) pair has a learned embedding, and a step's 7
#   embeddings are averaged into one token.
# - **FAST** (Pertsch et al. 2025): a chunk of 8 actions is compressed with a discrete cosine
#   transform over time, scaled by 10 and rounded, flattened frequency-major and encoded by
#   byte-pair encoding (a vocabulary of 1024 fitted on our demonstrations; the paper
#   fine-tunes FAST's DROID tokenizer, which cannot be downloaded here). Our per-step pooling
#   is our own design: step $t$ is tokenized as the chunk of the 8 actions ending at $t$ and
#   its tokens' embeddings (plus position embeddings) are averaged, so a step's token never
#   sees later actions, which a causal policy requires.
# - **VQ-VAE** (van den Oord et al. 2017): an MLP encoder, the nearest of $K$ codebook
#   vectors, a decoder; the codebook and commitment losses keep codes and encoder together,
#   and a straight-through estimator carries gradients past the quantizer.
# - **LFQ-VAE** (MAGVIT-v2): lookup-free quantization: the encoder outputs $\log_2 K$ numbers
#   and each is replaced by its sign, so the code is a bit pattern; an entropy loss spreads
#   the codes. (The official code's "LFQ-VAE" only L2-normalizes the encoder output; ours is
#   the method the paper cites.)
# - **LipVQ-VAE** (the paper): a VQ-VAE whose every encoder layer is normalized by Eq. 4,
#   with the $10^{-6}$ Lipschitz term of Eq. 5 ({doc}`chapter 3 <03_lipschitz_normalization>`
#   draws it). The official code's variant (`lipvq-official` below) normalizes only the last
#   layer, with a sigmoid output and no straight-through estimator.
#
# :::{dropdown} The tokenizers that came after the paper: FSQ, residual VQ, B-spline (click to open)
# And the tokenizers that came after the paper (compared inside ICRT in
# {doc}`chapter 12 <12_tokenizers_since_the_paper>`), each learned one also with Eq. 4 on
# every encoder layer (`lipfsq`, `liprvq`: the same layers and the same loss term as
# LipVQ-VAE's):
#
# - **FSQ** (Mentzer et al. 2023, used by QueST and OAT): the encoder outputs a few numbers,
#   each bounded by a tanh and rounded to one of $L_i$ levels, so the code is a point of a
#   fixed grid of $\prod_i L_i$ points; there is no codebook to learn or to collapse
#   (`vector_quantize_pytorch.FSQ`).
# - **Residual VQ** (VQ-BeT's tokenizer): $Q$ codebooks in turn, each quantizing what the
#   ones before it left, so a step's code is one entry per level and the quantized latent
#   their sum (`vector_quantize_pytorch.ResidualVQ`, codebooks updated by moving averages).
#   `codes/level` counts the codes each level uses: residual VQ can collapse level by level.
# - **B-spline** (BEAST, Zhou et al. 2025): each chunk of actions ending at a step is fitted
#   by a clamped cubic B-spline with $K$ control points per dimension (least squares), and
#   the control points are quantized to 256 integer bins; decoding evaluates the spline.
#   Nothing is learned but the token embeddings, as for Bin and FAST.
# :::
#
# ## Encode and decode, in the library
#
# Every tokenizer is an `nn.Module` whose forward pass takes actions $(B, T, 7)$ and returns
# one embedding per step (the action token), the discrete codes where there are any, its
# reconstruction of the actions and its losses. Each tokenizer's forward pass, from its
# module (click to open):
#
# :::{dropdown} MLP: encode with an MLP, decode with its mirror
# ```{literalinclude} /src/icil_paper/tokenizers/mlp.py
# :pyobject: MLPTokenizer._forward
# :dedent: 4
# :caption: src/icil_paper/tokenizers/mlp.py
# ```
# :::
# :::{dropdown} Bin: a bin per dimension, embeddings averaged; decode to bin centres
# ```{literalinclude} /src/icil_paper/tokenizers/bin.py
# :pyobject: BinTokenizer._forward
# :dedent: 4
# :caption: src/icil_paper/tokenizers/bin.py
# ```
# :::
# :::{dropdown} FAST: DCT, rounding and byte-pair encoding of the chunk ending at each step
# ```{literalinclude} /src/icil_paper/tokenizers/fast.py
# :pyobject: FASTTokenizer._forward
# :dedent: 4
# :caption: src/icil_paper/tokenizers/fast.py
# ```
# :::
# :::{dropdown} VQ-VAE: the nearest code (Eq. 2)
# ```{literalinclude} /src/icil_paper/tokenizers/vq.py
# :pyobject: VQTokenizer.quantize
# :dedent: 4
# :caption: src/icil_paper/tokenizers/vq.py
# ```
# :::
# :::{dropdown} VQ-VAE and LipVQ-VAE: encode, quantize, straight-through, decode
# ```{literalinclude} /src/icil_paper/tokenizers/vq.py
# :pyobject: VQTokenizer._forward
# :dedent: 4
# :caption: src/icil_paper/tokenizers/vq.py
# ```
# :::
# :::{dropdown} LFQ-VAE: lookup-free quantization
# ```{literalinclude} /src/icil_paper/tokenizers/lfq.py
# :pyobject: LFQTokenizer._forward
# :dedent: 4
# :caption: src/icil_paper/tokenizers/lfq.py
# ```
# :::
#
# LipVQ-VAE is `VQTokenizer` with `LipschitzLinear` encoder layers
# ({doc}`chapter 3 <03_lipschitz_normalization>` shows the layer). Each runs below on the
# first 20 steps of one minimum-jerk trajectory: the codes of its first steps, its
# embedding's shape and how well it reconstructs the actions, untrained (Bin and FAST are
# fitted to 8 trajectories first; nothing else is learned yet).

# %%
# teaches: each tokenizer's encode and decode, run
import torch

from icil_paper.data.trajectories import generate_trajectories
from icil_paper.tokenizers import make_tokenizer

torch.manual_seed(0)
trajectories = generate_trajectories(8, seed=0)  # 8 minimum-jerk (T, 7) action trajectories
actions = torch.as_tensor(trajectories[0][None, :20], dtype=torch.float32)  # (1, 20, 7)
for name in ("mlp", "bin", "fast", "vq", "lfq", "lipvq"):
    tokenizer = make_tokenizer(name, action_dim=7).fit(trajectories).eval()
    with torch.no_grad():
        out = tokenizer(actions)
    codes = None if out.codes is None else out.codes[0, 0].tolist()
    error = float(((out.reconstruction - actions) ** 2).mean())
    print(f"{name:5s} tokens {tuple(out.embeddings.shape)}, reconstruction MSE {error:.2g}")
    print(f"      codes of step 1: {codes}")

# %% [markdown]
# ## What this chapter measures
#
# In the paper every tokenizer is trained jointly with the policy (that is Table III, in
# {doc}`chapter 8 <08_smoothness>`); here each is trained on its own, as an autoencoder of
# action trajectories, to isolate the tokenizer: reconstruction error, codebook usage and
# perplexity, tokens per step, encode / decode throughput on CPU, and two smoothness scores
# of the embeddings a policy would consume:
#
# - `least_energy`, the paper's score, $\sum_t \|z_{t+2} - 2 z_{t+1} + z_t\|^2$. It grows with
#   the square of the latent scale, so a tokenizer with small latents scores low whatever
#   the shape of its curve;
# - `least_energy_standardized`, the same on $z / \sigma$, where $\sigma$ is the standard
#   deviation of the latents over the held-out set: multiplying every latent by a constant
#   leaves it unchanged, and it still separates a curve that jumps once from one that jumps
#   three times.
#
# Each tokenizer is trained with the preset's number of seeds; every number below is the
# mean over seeds and held-out trajectories with a bootstrap 95% interval. The action
# trajectories are the preset's `generated` demonstrations of Table I's Meta-World tasks
# and of every ManiSkill task ({doc}`chapter 4 <04_tasks_and_demonstrations>`: scripted
# experts on seeded layouts, the stand-in for MimicGen data), with a fifth of each task's
# demos held out for the metrics (`icil_paper.book.studies.tokenizer_trajectories`).

# %% tags=["hide-input"]
from IPython.display import display

from icil_paper.book.components import (
    paper_tokenizer_smoothness,
    smoothness_figure,
    tokenizer_frames,
)
from icil_paper.book.studies import SeedRecords, tokenizer_latent_recording, tokenizer_study
from icil_paper.config import get_preset
from icil_paper.results import ResultsStore
from icil_paper.tokenizers import TOKENIZERS
from icil_paper.viz.viewer import show_recording

preset = get_preset()  # reads ICIL_PRESET
store = ResultsStore(preset.name)
SMOOTHNESS = paper_tokenizer_smoothness()  # the paper's least energy (Table III), by tokenizer

# %%
records = tokenizer_study(preset, store)  # {label: [metrics per seed]}; trains what is missing
seeds = SeedRecords(records)  # means, intervals and verdicts over training seeds
print(f"{len(records)} tokenizers, {seeds.n_seeds} training seed(s) each")

# %% [markdown]
# ## The table
#
# `recon MSE` is the tokenizer's own reconstruction (decoder; bin centres for `bin`, inverse
# DCT for `fast`); `decode MSE` decodes the embeddings (a learned head for `bin` and `fast`).
# Usage is the share of the codebook seen on held-out trajectories, perplexity the number of
# equally used codes with the same entropy. Throughput is per CPU core (one torch thread).
# The paper's least energy is shown beside ours; it was measured on RoboCasa latents of
# policies trained jointly, so only the ranking is comparable.
#
# Besides the tokenizers that came after the paper (`fsq` to `bspline`), three rows are not
# the paper's tokenizers: `lipvq-official` is the official code's variant,
# and `vq-data-init` / `lipvq-data-init` start their codebooks from encoder outputs instead
# of VQ-VAE's uniform $(-1/K, 1/K)$ initialisation. A VQ tokenizer whose trajectory stays
# on one code has zero least energy whatever its encoder does, so these two rows tell
# whether a low score comes from the Lipschitz bound or from codebook collapse.

# %% tags=["hide-cell"]
properties, smoothness = tokenizer_frames(seeds, SMOOTHNESS)
display(properties)
display(smoothness)

# %% tags=["hide-cell"]
display(smoothness_figure(seeds, SMOOTHNESS))

# %% [markdown]
# ## Latent trajectories
#
# The same held-out trajectory through every latent space, in principal components (each
# path scaled to unit extent, so shapes compare and scales do not). The rerun recording
# holds the 3-D paths side by side, with a point moving along each one step by step beside
# the action curves, in the embedded viewer (the file is linked for download; the static
# picture shows where the viewer cannot start). Seed 0's tokenizers.

# %%
latent_recording = tokenizer_latent_recording(preset, records)
display(show_recording(latent_recording["rrd"], latent_recording["png"],
                       label="latent trajectories"))

# %% [markdown]
# ## What we found
#
# "Smoother" is decided by the paired difference of two tokenizers' mean scores over the
# same held-out trajectories (seeds resampled too): it holds when the whole 95% interval
# lies below 0. The table gives each Lipschitz variant against its base; the prose below it
# quotes the numbers of the run this book was built from.

# %% tags=["remove-cell"]
import pandas as pd
from myst_nb import glue

from icil_paper import stats
from icil_paper.book.components import LOW_USAGE, TOKENIZER_SCORES
from icil_paper.metrics import ascending, rank_correlation
from icil_paper.verdict_words import SMOOTHER

paper_names = [k for k in TOKENIZERS if k in SMOOTHNESS]
glue("ch05_paper_rank", ", ".join(ascending(SMOOTHNESS)))
for key in TOKENIZER_SCORES:
    ours = {k: float(seeds.scores(k, key).mean()) for k in paper_names}
    glue(f"ch05_rank_{key}", ", ".join(ascending(ours)))
    glue(f"ch05_rho_{key}", rank_correlation(ours, SMOOTHNESS))
PAIRS = {"Eq. 4 on VQ-VAE (LipVQ-VAE against VQ-VAE)": ("lipvq", "vq"),
         "the same, codebooks initialised from data": ("lipvq-data-init", "vq-data-init"),
         "Eq. 4 on FSQ": ("lipfsq", "fsq"), "Eq. 4 on residual VQ": ("liprvq", "rvq")}
rows = {}
for name, (a, b) in PAIRS.items():
    for key in TOKENIZER_SCORES:
        est = stats.paired_score_difference(seeds.scores(a, key), seeds.scores(b, key))
        word = SMOOTHER[stats.verdict(est, direction=-1)]
        rows.setdefault(name, {})[key] = f"{est.value:+.3g} [{est.low:+.3g}, {est.high:+.3g}]: {word}"
        if a == "lipvq":
            glue(f"ch05_lipvq_{key}", word)
comparisons = pd.DataFrame(rows).T
glue("ch05_comparisons", comparisons)
glue("ch05_scale_lipvq", seeds.mean("lipvq", "latent_scale"))
glue("ch05_scale_vq", seeds.mean("vq", "latent_scale"))
low_usage = [k for k in seeds.records
             if seeds.mean(k, "usage") is not None and seeds.mean(k, "usage") < LOW_USAGE]
glue("ch05_collapsed", ", ".join(low_usage) or "none")
glue("ch05_low_usage", LOW_USAGE)
glue("ch05_official_codes", seeds.mean("lipvq-official", "codes_used"))
glue("ch05_official_mse", seeds.mean("lipvq-official", "reconstruction_mse"))
glue("ch05_lipvq_codes", seeds.mean("lipvq", "codes_used"))
glue("ch05_lipvq_mse", seeds.mean("lipvq", "reconstruction_mse"))
rates = {k: seeds.mean(k, "encode_decode_actions_per_s") for k in seeds.records}
glue("ch05_slowest", min(rates, key=rates.get))
glue("ch05_slowest_rate", min(rates.values()))
glue("ch05_fastest", max(rates, key=rates.get))
glue("ch05_fastest_rate", max(rates.values()))
glue("ch05_fast_tokens", seeds.mean("fast", "tokens_per_step"))
glue("ch05_rvq_levels", seeds.per_level("rvq"))
glue("ch05_liprvq_levels", seeds.per_level("liprvq"))

# %% [markdown]
# :::{dropdown} Each Lipschitz variant against its base: difference [95% interval]: verdict
# ```{glue:} ch05_comparisons
# ```
# :::
#
# **Rankings.** The paper ranks the tokenizers, smoothest first: {glue:text}`ch05_paper_rank`.
# By the paper's least energy ours are {glue:text}`ch05_rank_least_energy` (rank correlation
# with the paper's {glue:text}`ch05_rho_least_energy:+.2f`); by the standardized score
# {glue:text}`ch05_rank_least_energy_standardized`
# ({glue:text}`ch05_rho_least_energy_standardized:+.2f`).
#
# **The Lipschitz constraint alone.** Against VQ-VAE, LipVQ-VAE is
# {glue:text}`ch05_lipvq_least_energy` by the paper's least energy and
# {glue:text}`ch05_lipvq_least_energy_standardized` by the standardized score. The raw score
# grows with the square of the latent scale σ, which is {glue:text}`ch05_scale_lipvq:.3g`
# for LipVQ-VAE and {glue:text}`ch05_scale_vq:.3g` for VQ-VAE: the standardized score is
# the one that compares shapes.
#
# **Codebooks.** Tokenizers that use under {glue:text}`ch05_low_usage:.0%` of their codes on
# held-out data (collapse): {glue:text}`ch05_collapsed`. The official code's LipVQ variant
# (sigmoid output, no straight-through) uses {glue:text}`ch05_official_codes:.0f` code(s)
# and reconstructs with MSE {glue:text}`ch05_official_mse:.3g`, against
# {glue:text}`ch05_lipvq_codes:.0f` codes and {glue:text}`ch05_lipvq_mse:.3g` for the
# paper's. Residual VQ uses {glue:text}`ch05_rvq_levels` codes per level,
# {glue:text}`ch05_liprvq_levels` with Eq. 4.
#
# **Cost.** Encode plus decode on one core runs from {glue:text}`ch05_slowest_rate:,.0f`
# actions/s ({glue:text}`ch05_slowest`) to {glue:text}`ch05_fastest_rate:,.0f`
# ({glue:text}`ch05_fastest`); FAST emits {glue:text}`ch05_fast_tokens:.2f` tokens per step.
