# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # 14. Your own tokenizer against the paper's
#
# **The question.** The paper asks whether the action tokenizer matters in in-context
# imitation, and answers with LipVQ-VAE. Whoever builds a tokenizer asks the next question:
# is mine better than LipVQ-VAE, on the same protocol, with the same statistics? This
# chapter answers it for a tokenizer written outside the package, in one file, and shows
# the one command that does it for yours.
#
# **How.** A tokenizer is an `ActionTokenizer` subclass and its config, registered by one
# decorator (`@register_tokenizer`, {doc}`chapter 5 <05_action_tokenizers>`). A file or
# module that does that is a *plugin*: `--plugin FILE_OR_MODULE` on any command loads it, and
# an installed package can declare it once, as an entry point of the group
# `icil_paper.tokenizers`, for every command and process to find:
#
# ```toml
# [project.entry-points."icil_paper.tokenizers"]
# chunkbins = "my_tokenizers.chunk_bins"
# ```
#
# A plugin is checked before any work: a module that does not exist or registers nothing, a
# name a built-in already has, a config field without a default, a config that does not
# check its values, and an encoder whose output on a probe batch has the wrong shape each
# stop the command with one line. It then travels to every grid worker (the local pool and
# Ray), and every record it makes names it with its file's SHA-256 (or its package's
# version). Then:
#
# ```bash
# icil-paper compare --plugin chunk_bins.py --tokenizer chunkbins --against lipvq \
#     --preset small --effect 0.05
# ```
#
# trains and evaluates the rows the comparison needs on Table I's protocol
# ({doc}`chapter 6 <06_table1_kitchen>`: one ICRT policy per row and seed, trained on Table
# I's 13 Meta-World tasks, evaluated on the same episodes as every other row), reusing every stored
# cell, and reads the difference of average success as the claims ledger reads a claim
# ({doc}`chapter 0 <00_claims_ledger>`): an interval with the training seed as the unit,
# the verdict, its size against the effect of interest and the power of the design. The
# seeds come from the measured variances: two seeds a row first, then as many as detect the
# effect with 80% power (at most `--max-seeds`).

# %% tags=["hide-input"]
from IPython.display import Image, Markdown, display

from icil_paper.book.own_tokenizer import (
    CHAPTER_MAX_SEEDS,
    EXAMPLE_NAME,
    example_folder,
    own_tokenizer_study,
    write_example,
)
from icil_paper.config import get_preset
from icil_paper.tables.compare import MAX_SEEDS, PLOT_FILE, lines

preset = get_preset()  # reads ICIL_PRESET

# %% [markdown]
# ## The tokenizer: one file
#
# Uniform bins over chunks of actions: every dimension of each of a step's last four
# actions falls in one of 32 bins over [-1, 1], and the step's embedding is the sum of a
# learned embedding per (position, dimension, bin). It is a deliberately plain tokenizer
# (no encoder, no codebook learning), in about forty lines that use nothing but the
# library's interface. The chapter writes it to a file beside this build's results:

# %%
path = write_example(example_folder(preset))
display(Markdown(f"`{path.name}`:\n\n```python\n{path.read_text()}```"))

# %% [markdown]
# ## The comparison
#
# The next cell is what `icil-paper compare --plugin chunk_bins.py --tokenizer chunkbins`
# runs: it loads the file as a plugin, trains and evaluates what is not stored, and writes
# `compare.json` and `compare.png` beside the file. LipVQ-VAE's cells are Table I's (at the
# reference preset, its ten reference seeds). This build caps the seeds a row at
# the number below, so that CI's reproduction stays within its minutes; the report then
# says how much power that design has and how many seeds a row would detect the effect.

# %%
print("seeds a row at most:", CHAPTER_MAX_SEEDS.get(preset.name, MAX_SEEDS))
report = own_tokenizer_study(preset)  # computes what this build's results store lacks
print("\n".join(lines(report)))

# %%
display(Image(filename=str(example_folder(preset) / PLOT_FILE)))

# %% [markdown]
# ## What we found

# %% tags=["remove-cell"]
from myst_nb import glue

from icil_paper.verdict_words import claim_words

entry = report["comparisons"][0]
glue("ch14_name", EXAMPLE_NAME)
glue("ch14_diff", float(entry["ours"]) if entry.get("ours") is not None else "n/a")
glue("ch14_low", float(entry["ci"][0]) if entry.get("ci") else "n/a")
glue("ch14_high", float(entry["ci"][1]) if entry.get("ci") else "n/a")
glue("ch14_verdict", claim_words(entry["verdict"], "above" if entry.get("direction", 1) > 0 else "below"))
glue("ch14_mde", float(entry["mde"]) if entry.get("mde") is not None else "n/a")
glue("ch14_power", float(entry["power"]) if entry.get("power") is not None else "n/a")
glue("ch14_effect", float(report["effect"]))
glue("ch14_seeds", report["seed_plan"].get("note") or "fixed")

# %% [markdown]
# `{glue:text}`ch14_name`` minus LipVQ-VAE in average success is
# {glue:text}`ch14_diff:+.3f` (95% interval {glue:text}`ch14_low:+.3f` to
# {glue:text}`ch14_high:+.3f`): the claim that it succeeds more {glue:text}`ch14_verdict`. This design
# detects a difference of {glue:text}`ch14_mde:.3f` with 80% power; an effect of
# {glue:text}`ch14_effect` it detects with probability {glue:text}`ch14_power:.2f`. Seeds:
# {glue:text}`ch14_seeds`. In the quick run (CI's small preset: it tests the code, not the
# question) these numbers come from a few hundred training steps and one episode a task;
# at the reference preset the same command reuses LipVQ-VAE's cells from our run and
# plans the new row's seeds from their variance.
