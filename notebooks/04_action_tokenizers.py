# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # 4. Action tokenizers on their own
#
# **What the paper claims (Sec. IV, Table III).** The action tokenizer decides how well
# in-context imitation works, and smoother latent trajectories go with higher success.
# Scored by the least energy of the latent trajectory (lower is smoother), the paper ranks
# LipVQ-VAE smoothest (0.63), then LFQ-VAE, VQ-VAE, FAST, MLP, and Bin last.
#
# Here every tokenizer of the paper (`icil_paper.tokenizers`) is trained on its own, as an
# autoencoder of action trajectories, and measured the same way: reconstruction error,
# codebook usage and perplexity, tokens per step, encode / decode throughput on CPU and three
# smoothness scores of the embeddings a policy would consume:
#
# - `least_energy`, the paper's score, $\sum_t \|z_{t+2} - 2 z_{t+1} + z_t\|^2$. It scales with
#   the square of the latent scale, so a tokenizer with small latents scores low whatever
#   the shape of its curve;
# - `least_energy_normalized`, the same on the curve rescaled to unit mean squared step;
# - `curvature_energy`, Horn's discrete curve energy (squared turning angles over segment
#   lengths) times the curve length.
#
# The last two give the same value for $z$ and $10z$. In the paper the tokenizers are
# trained jointly with the policy; here they are trained alone, so these numbers isolate
# the tokenizer. The action trajectories are the preset's `generated` demonstrations of
# every kitchen and ManiSkill task (chapter 03: our scripted experts on randomized scenes,
# the stand-in for MimicGen data), with a fifth of each task's demos held out for the
# metrics below (`icil_paper.studies.tokenizer_trajectories`).

# %%
import matplotlib.pyplot as plt
import pandas as pd
from IPython.display import display

from icil_paper.config import get_preset
from icil_paper.metrics import ascending, rank_correlation
from icil_paper.paper_numbers import SMOOTHNESS
from icil_paper.results import ResultsStore
from icil_paper.studies import tokenizer_latent_recording, tokenizer_study
from icil_paper.tokenizers import TOKENIZERS
from icil_paper.viewer import show_recording

preset = get_preset()  # reads ICIL_PRESET
store = ResultsStore(preset.name)

# %%
records = tokenizer_study(preset, store)  # trains what the results store lacks

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
# Three rows are not the paper's tokenizers: `lipvq-official` is the official code's variant
# (see chapter 02), and `vq-data-init` / `lipvq-data-init` start their codebooks from encoder
# outputs instead of VQ-VAE's uniform $(-1/K, 1/K)$ initialisation. A VQ tokenizer whose
# trajectory stays on one code has zero least energy whatever its encoder does, so these two
# rows tell whether a low score comes from the Lipschitz bound or from codebook collapse.

# %%
rows = []
for label, m in records.items():
    rows.append({
        "tokenizer": label,
        "recon MSE": m["reconstruction_mse"],
        "decode MSE": m["decode_mse"],
        "codebook": m["codebook_size"],
        "usage": m["usage"],
        "perplexity": m["perplexity"],
        "tokens/step": m["tokens_per_step"],
        "encode act/s": m["encode_actions_per_s"],
        "decode act/s": m["decode_actions_per_s"],
        "least energy": m["least_energy"],
        "LE normalized": m["least_energy_normalized"],
        "curvature energy": m["curvature_energy"],
        "paper least energy": SMOOTHNESS.get(label),
    })
table = pd.DataFrame(rows).set_index("tokenizer")
formats = {"codebook": "{:,.0f}", "usage": "{:.1%}", "perplexity": "{:.1f}",
           "tokens/step": "{:.2f}", "encode act/s": "{:,.0f}", "decode act/s": "{:,.0f}"}
table.style.format({c: formats.get(c, "{:.3g}") for c in table.columns}, na_rep="-")

# %%
scores = ["least_energy", "least_energy_normalized", "curvature_energy"]
labels = list(records)
fig, axes = plt.subplots(1, 4, figsize=(16, 3.6))
for ax, score in zip(axes[:3], scores, strict=True):
    values = [records[k][score] for k in labels]
    ax.bar(range(len(labels)), values, color=["C3" if k == "lipvq" else "C0" for k in labels])
    ax.set_xticks(range(len(labels)), labels, rotation=60)
    ax.set_yscale("log")
    ax.set_title(score.replace("_", " ") + " (ours, lower is smoother)")
paper_labels = [k for k in labels if k in SMOOTHNESS]
axes[3].bar(range(len(paper_labels)), [SMOOTHNESS[k] for k in paper_labels], color="C7")
axes[3].set_xticks(range(len(paper_labels)), paper_labels, rotation=60)
axes[3].set_title("least energy (the paper, Table III)")
plt.tight_layout()

# %% [markdown]
# ## Latent trajectories
#
# The same held-out trajectory through every latent space, in principal components (each
# path scaled to unit extent, so shapes compare and scales do not). The rerun recording
# holds the 3-D paths side by side, with a point moving along each one step by step beside
# the action curves; open it with `rerun <file>`. The picture below is its static view.

# %%
latent_recording = tokenizer_latent_recording(preset, records)
display(show_recording(latent_recording["rrd"], latent_recording["png"],
                       label="latent trajectories"))

# %% [markdown]
# ## What we found

# %%
paper_names = [k for k in TOKENIZERS if k in SMOOTHNESS]
lines = [f"Paper's smoothness ranking (smoothest first): {', '.join(ascending(SMOOTHNESS))}."]
for score in scores:
    ours = {k: records[k][score] for k in paper_names}
    best = ascending(ours)[0]
    lines.append(
        f"Our {score} ranking: {', '.join(ascending(ours))}; rank correlation with the paper's "
        f"{rank_correlation(ours, SMOOTHNESS):+.2f}. LipVQ-VAE is "
        + ("the smoothest, as the paper claims." if best == "lipvq"
           else f"not the smoothest here ({best} is), so the paper's claim did not hold "
                "on this score in our run."))
lip, vq = records["lipvq"], records["vq"]
lines.append(
    f"LipVQ-VAE vs VQ-VAE (the Lipschitz constraint alone): least energy "
    f"{lip['least_energy']:.4g} vs {vq['least_energy']:.4g}, normalized "
    f"{lip['least_energy_normalized']:.4g} vs {vq['least_energy_normalized']:.4g}, curvature "
    f"{lip['curvature_energy']:.4g} vs {vq['curvature_energy']:.4g}; reconstruction MSE "
    f"{lip['reconstruction_mse']:.4g} vs {vq['reconstruction_mse']:.4g}.")
low_usage = [k for k in records if records[k]["usage"] is not None and records[k]["usage"] < 0.1]
if low_usage:
    lines.append("Codebook collapse (under 10% of codes used on held-out data): "
                 + ", ".join(f"{k} ({records[k]['codes_used']} of {records[k]['codebook_size']})"
                             for k in low_usage) + ".")
init = {k: records[f"{k}-data-init"] for k in ("vq", "lipvq")}
smoother = lambda a, b: "smoother" if a < b else "not smoother"
lines.append(
    "Codebooks initialised from encoder outputs (not the paper's method): vq uses "
    f"{init['vq']['codes_used']} codes (MSE {init['vq']['reconstruction_mse']:.4g}), lipvq "
    f"{init['lipvq']['codes_used']} (MSE {init['lipvq']['reconstruction_mse']:.4g}). "
    + " ".join(
        f"On {score}, lipvq is {smoother(init['lipvq'][score], init['vq'][score])} than vq with "
        f"this initialisation ({init['lipvq'][score]:.4g} vs {init['vq'][score]:.4g}), and "
        f"{smoother(lip[score], vq[score])} with the paper's uniform one."
        for score in scores))
off = records["lipvq-official"]
lines.append(
    f"The official code's LipVQ variant (sigmoid output, no straight-through) uses "
    f"{off['codes_used']} code(s) and reconstructs with MSE {off['reconstruction_mse']:.4g}, "
    f"against {lip['codes_used']} codes and {lip['reconstruction_mse']:.4g} for the paper's.")
fastest = max(records, key=lambda k: records[k]["encode_decode_actions_per_s"])
slowest = min(records, key=lambda k: records[k]["encode_decode_actions_per_s"])
lines.append(
    f"Throughput (encode + decode, one core): from {records[slowest]['encode_decode_actions_per_s']:,.0f} "
    f"actions/s ({slowest}) to {records[fastest]['encode_decode_actions_per_s']:,.0f} ({fastest}). "
    f"FAST emits {records['fast']['tokens_per_step']:.2f} tokens per step, bin "
    f"{records['bin']['tokens_per_step']:.0f}, the others one embedding per step.")
print("\n\n".join(lines))
