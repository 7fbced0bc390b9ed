# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     name: python3
#     display_name: Python 3
# ---

# %% [markdown]
# # 2. ICRT: in-context imitation as next-token prediction
#
# **What the paper claims (Sec. III-A).** The paper builds on ICRT (Fu et al. 2024): a causal
# transformer reads a *prompt* (one full demonstration of the task) as interleaved
# observation and action tokens, then the *query*, the observations of the episode being
# played, and predicts the query's actions (Eq. 1):
#
# $$\underbrace{(h^o_{p,1}, h^a_{p,1}, \dots, h^o_{p,M}, h^a_{p,M})}_{\text{prompt}},\;
#   \underbrace{(h^o_{q,1}, h^o_{q,2}, \dots, h^o_{q,N})}_{\text{query}}$$
#
# Observation tokens come from an observation backbone (MLPs for low-dimensional state,
# ResNet-18 for images, CLIP for language), action tokens from an *action tokenizer*, the
# subject of the paper. The transformer "outputs tokens only for the query while masking
# those corresponding to the prompt"; an MLP decodes them into actions, trained by behaviour
# cloning. At inference the model "processes only one query observation at a time".
#
# This chapter opens the model up on real data: the token layout of a training batch, the
# attention mask, what the loss reaches, and a small ICRT (with the paper's LipVQ-VAE
# tokenizer) trained on one Meta-World task, `metaworld/drawer-open`, and rolled out from a
# prompt demonstration.
#
# Two choices of ours, both ICRT's own (its code, see `icil_paper.policies.icrt`): the query
# carries its own past actions too ($o_{q,1}, a_{q,1}, o_{q,2}, \dots$; `ICRTConfig.
# query_actions=False` gives Eq. 1 literally), and the head predicts a chunk of
# `chunk_size` future actions at each query observation token.
#
# **ICRT (the paper's Fig. 2)**: prompt and query tokens in one causal sequence; the loss
# is on the query's predicted actions only.
#
# ```text
#  prompt: one demonstration of the task            query: the episode being played
#  o_p1  a_p1  o_p2  a_p2  ...  o_pM  a_pM          o_q1  a_q1  o_q2  ...  o_qt
#   |     |                                           |     |            |
#   |     +- action tokenizer (MLP, Bin, FAST,        |     +- same      |
#   |        VQ-VAE, LFQ-VAE or LipVQ-VAE), MLP       |                  |
#   +- observation backbone (state MLP; ResNet-18 for images)            |
#                          causal transformer (RMSNorm, RoPE, SwiGLU)
#                                                                        |
#                            MLP head at the query's observation tokens: a_t .. a_(t+K-1)
# ```

# %% tags=["hide-input"]
import logging

import matplotlib.pyplot as plt
from IPython.display import display
from matplotlib.colors import ListedColormap

from icil_paper.book.method import (
    attention_mask_figure,
    loss_coverage,
    loss_gradient_figure,
    replay_episode,
    rollout_figure,
    study_metrics,
    training_figure,
)
from icil_paper.book.report import load_table
from icil_paper.config import get_preset
from icil_paper.data import ensure_demos, load_demos
from icil_paper.eval import record_rollout
from icil_paper.paper.icrt_demo import (
    ICRT_DEMO_TASK,
    ICRT_DEMO_TOKENIZER,
    icrt_records,
    icrt_specs,
)
from icil_paper.policies import make_policy
from icil_paper.policies.batching import obs_spec_from_obs
from icil_paper.policies.inspection import token_loss_gradients, token_roles
from icil_paper.policies.transformer import causal_mask
from icil_paper.results import ResultsStore, results_root
from icil_paper.seeding import seed_everything
from icil_paper.train import load_trained
from icil_paper.viz.viewer import show_recording

logging.getLogger("robosuite_logs").disabled = True  # robosuite's import-time chatter
preset = get_preset()  # reads ICIL_PRESET
TASK, TOKENIZER = ICRT_DEMO_TASK, ICRT_DEMO_TOKENIZER
store = ResultsStore(preset.name)
run, evaluation = icrt_specs(preset)  # the run spec (data, configs, training) and rollouts
rng = seed_everything(run.seed)
demos = load_demos(ensure_demos(preset, TASK, "generated", n=run.data.demos_per_task),
                   limit=run.data.demos_per_task)
lengths = [len(d.actions) for d in demos]
print(f"{len(demos)} demonstrations of {TASK}, {min(lengths)}-{max(lengths)} steps")
print(f"d_model {run.policy.d_model}, {run.policy.n_layer} layers, {run.train.steps} steps")

# %% [markdown]
# ## The token layout of a real batch
#
# A training batch pairs each query (by default a whole demonstration from step 0, as the
# policy acts; with `query_len > 0`, a window of that many steps) with a prompt: another
# full demonstration of the same task. Prompts differ in length, so the
# batch is padded; padding is never attended to and does not shift the positions of real
# tokens (rotary positions count real tokens only).
#
# The policy assembles Eq. 1's sequence in `ICRT.sequence`: each prompt step's observation
# token and action token side by side, then the query's, in one tensor:
#
# ```{literalinclude} /src/icil_paper/policies/icrt.py
# :pyobject: ICRT.sequence
# :dedent: 4
# :caption: src/icil_paper/policies/icrt.py (Eq. 1's token layout)
# ```
#
# Below it runs on a batch of three sequences; the picture colours each token by its role.

# %% tags=["hide-input"]
# teaches: Eq. 1's token layout, read from a real batch
policy = make_policy(run.policy, obs_spec_from_obs(demos[0].obs), 7, run.tokenizer)
data = policy.prepare(demos)
batch = policy.sample_batch(data, 3, rng)
roles = token_roles(policy, batch)

# one colour per role: prompt obs, prompt action, query obs, query action, padding
role = (2 * roles["segment"] + roles["kind"]).numpy()
role[~roles["valid"].numpy()] = 4
colours = ListedColormap(["#4C72B0", "#A6C8EC", "#DD8452", "#F5C9A2", "#EEEEEE"])
fig, ax = plt.subplots(figsize=(12, 1.8))
ax.imshow(role, aspect="auto", cmap=colours, vmin=-0.5, vmax=4.5, interpolation="nearest")
ax.set_yticks(range(role.shape[0]), [f"sequence {b}" for b in range(role.shape[0])])
ax.set_xlabel("token position")
handles = [plt.Rectangle((0, 0), 1, 1, color=colours(i)) for i in range(5)]
ax.legend(handles, ["prompt obs", "prompt action", "query obs", "query action", "padding"],
          ncol=5, loc="upper center", bbox_to_anchor=(0.5, -0.45), frameon=False)
ax.set_title("Eq. 1 from a real batch: prompt (a whole demonstration), then the query")
plt.show()

names = {(0, 0): "o_p", (0, 1): "a_p", (1, 0): "o_q", (1, 1): "a_q"}
b = 0
real = roles["valid"][b].nonzero().flatten().tolist()
labels = [f"{names[(int(roles['segment'][b, i]), int(roles['kind'][b, i]))]}{int(roles['step'][b, i]) + 1}"
          for i in real]
M = int(batch["prompt_valid"][b].sum())
print("sequence 0:", " ".join(labels[:6]), "...", " ".join(labels[2 * M - 2:2 * M + 6]), "...",
      " ".join(labels[-4:]))
Q = int(batch["query_valid"][b].sum())
print(f"  prompt: {M} steps = {2 * M} tokens; query: {Q} steps; padded length {role.shape[1]} tokens")

# %% [markdown]
# ## The attention mask
#
# Each token attends to itself and every real token to its left (white = may attend). The
# query's observation token of step $t$ sees the whole prompt and the query's past, but not
# the action $a_{q,t}$ it must predict, which comes right after it. The transformer builds
# the mask from the batch's padding alone:
#
# ```{literalinclude} /src/icil_paper/policies/transformer.py
# :pyobject: causal_mask
# :caption: src/icil_paper/policies/transformer.py (the causal mask)
# ```

# %% tags=["hide-output"]
tokens, valid, query_obs_index, _ = policy.sequence(batch)
print(f"tokens {tuple(tokens.shape)} (batch, positions, width)")
print(f"the query's observation tokens at positions {query_obs_index[:3].tolist()} ...")
b = int(batch["prompt_valid"].sum(1).argmin())  # the shortest prompt shows its padding
mask = causal_mask(roles["valid"][b:b + 1])[0, 0].numpy()
display(attention_mask_figure(mask, batch, b))
padded = batch["prompt_valid"].shape[1] - int(batch["prompt_valid"][b].sum())
print(f"keys attended to: {int(mask.sum())} of {mask.size}; padded prompt steps: {padded}")

# %% [markdown]
# ## What the loss covers
#
# The loss is an L1 between the predicted chunk and the next `chunk_size` demonstrated
# actions, at the query's observation tokens only, plus the tokenizer's own losses (the
# LipVQ-VAE's reconstruction, codebook, commitment and Lipschitz terms), trained jointly.
# Below: the size of the loss gradient at each position of the transformer's output. It is
# exactly zero on the prompt, on action tokens and on padding.

# %% tags=["hide-output"]
grads = token_loss_gradients(policy, batch)  # (B, L) |dL/dh| at each output position
display(loss_gradient_figure(grads))
coverage = loss_coverage(roles, grads)
print(coverage)  # tokens of each kind, and how many the loss reaches

# %% [markdown]
# ## A small ICRT, trained and rolled out
#
# One run of the library's training loop (`train_policy`: AdamW, warm-up and cosine decay,
# checkpoints in `runs/`), then `evaluate_policy`: rollouts from unseen initial scenes,
# each with a prompt demonstration drawn from the generated data set. The run is a table of
# one cell (`icil_paper.paper.icrt_demo`, the stage `table-icrt` of `icil-paper
# reproduce`), computed as every table's cells are; its train and eval records are stored
# in the results store under the run's key, so rebuilding the chapter only loads them.

# %% tags=["hide-cell"]
load_table(preset, "icrt")  # trains and evaluates the one cell, or finds its records
m = study_metrics(icrt_records(preset, store))  # the train and eval records merged
display(training_figure(m, f"ICRT + {TOKENIZER} on {TASK}"))
print(f"success {m['successes']}/{m['episodes']}")
print(f"Wilson 95% interval {m['ci_low']:.2f}-{m['ci_high']:.2f}")

# %% [markdown]
# One rollout, step by step: the trained policy, prompted with a demonstration it was
# trained on, acting in a scene it has not seen (evaluation seeds are disjoint from the
# demonstrations' seeds). The policy is loaded from the run folder (retrained, identically,
# if the folder is missing).

# %% tags=["hide-cell"]
trained_policy = load_trained(run, preset.name, store)
# a successful evaluation episode when there is one, replayed: same seed, same prompt
episode, prompt, trace = replay_episode(trained_policy, demos, m["per_episode"], TASK,
                                        evaluation.max_steps)
display(rollout_figure(trace, prompt[0]))
print(f"replayed: success {trace['success']} after {trace['steps']} steps")
print(f"stored evaluation: success {episode['success']} after {episode['steps']} steps")

# %% [markdown]
# The same rollout as a rerun recording, in the embedded viewer: the end effector's path
# and the object in 3-D, the actions, and the latent action tokens LipVQ-VAE made of them,
# on one step timeline (the file is linked for download; the static picture shows where
# the viewer cannot start).

# %% tags=["hide-input"]
recording = record_rollout(trained_policy, TASK, {"index": episode["episode"],
                                                  "seed": episode["seed"]},
                           trace, results_root() / preset.name / "icrt")
display(show_recording(recording, label=f"{TASK}, episode {episode['episode']}"))

# %% [markdown]
# ## Training as it acts: whole episodes or windows
#
# :::{dropdown} Why ICRT trains on whole episodes here, and what windows do (click to open)
# ICRT's code trains on 32-step query windows that start anywhere in an episode, while the
# policy acts from step 0 and for a whole episode: at step 100 it attends to 100 query steps
# of its own, which no training window showed it. Here ICRT trains on whole episodes from
# step 0 by default (`ICRTConfig.query_len = 0`, `query_start = "episode_start"`), and the
# window training is an option (`query_len=32`, `query_start="random"`). The analysis table
# ({doc}`chapter 11 <11_is_it_smoothness>`) trains ICRT + LipVQ-VAE both ways on Table I's
# Meta-World tasks; their success, from the records:
# :::

# %% tags=["remove-input", "hide-output"]
import pandas as pd

from icil_paper.paper.analysis import training_windows
from icil_paper.verdict_words import MISSING, TRAINING_WINDOW

rows = {}
for source, result in load_table(preset, "analysis", compute=False).items():
    w = training_windows(result)
    rows[source] = {"seeds a row": w["seeds"] if w else None,
                    "whole episodes": f"{w['whole'].value:.2f}" if w else MISSING,
                    "32-step windows": f"{w['windows'].value:.2f}" if w else MISSING,
                    "whole minus windows [95% CI]": f"{w['difference'].value:+.2f} [{w['difference'].low:+.2f}, {w['difference'].high:+.2f}]" if w else MISSING,
                    "that whole episodes help": TRAINING_WINDOW[w["verdict"]] if w else MISSING}
display(pd.DataFrame(rows).T)

# %% [markdown]
# ## What we found

# %% tags=["remove-cell"]
from myst_nb import glue

from icil_paper.paper.table_i import TABLE_I_ROBOCASA

paper_drawers = TABLE_I_ROBOCASA["icrt+lipvq"]["drawers"]
glue("ch02_query_reached", coverage["query_reached"])
glue("ch02_query", coverage["query"])
glue("ch02_prompt_reached", coverage["prompt_reached"])
glue("ch02_steps", m["train"]["steps"])
glue("ch02_loss_drop", float(m["loss"][0] / max(m["loss"][-1], 1e-12)))
glue("ch02_successes", m["successes"])
glue("ch02_episodes", m["episodes"])
glue("ch02_ci_low", float(m["ci_low"]))
glue("ch02_ci_high", float(m["ci_high"]))
glue("ch02_paper", float(paper_drawers))
glue("ch02_paper_inside", "inside" if m["ci_low"] <= paper_drawers <= m["ci_high"] else "outside")

# %% [markdown]
# **The loss covers what Sec. III-A says.** On a real batch the loss reached
# {glue:text}`ch02_query_reached` of the {glue:text}`ch02_query` supervised query observation
# tokens and {glue:text}`ch02_prompt_reached` prompt tokens: the prompt conditions the
# prediction and is never a target.
#
# **Training works, at this scale.** {glue:text}`ch02_steps` steps lowered the total loss
# {glue:text}`ch02_loss_drop:.1f`-fold. On drawer-open, ICRT + LipVQ-VAE succeeded in
# {glue:text}`ch02_successes` of {glue:text}`ch02_episodes` rollouts (95% interval
# {glue:text}`ch02_ci_low:.2f` to {glue:text}`ch02_ci_high:.2f`). The paper reports
# {glue:text}`ch02_paper:.2f` on RoboCasa's drawer family after 500K iterations on MimicGen
# data, {glue:text}`ch02_paper_inside` our interval; our task, data and training budget are
# stand-ins at a far smaller scale, so this chapter checks the mechanics, not the paper's
# number. A success rate over a few episodes of one task says little;
# {doc}`chapter 6 <06_table1_kitchen>` compares the policies properly.
