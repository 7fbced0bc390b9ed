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
# The answer first, for each source; how to read it follows the tables.

# %% tags=["hide-input"]
import pandas as pd
from IPython.display import display

from icil_paper.book.report import (
    EARLIER_RUNS,
    REFERENCE,
    chapter_ledgers,
    decision_rate,
    earlier_verdicts,
    ledger_frame,
    ledger_views,
    looks_frame,
    older_ledger,
    plan_frame,
    reference_freshness,
    reference_ledger,
    retired_records,
    run_progress,
    stale_records,
)
from icil_paper.config import get_preset
from icil_paper.planning.design import design_frame, stage_counts
from icil_paper.planning.staged import as_run
from icil_paper.results import ResultsStore
from icil_paper.tables.design import read_record
from icil_paper.tables.display import collapsed_frame

pd.set_option("display.max_colwidth", None)
preset = get_preset()
ledgers = chapter_ledgers(preset)  # writes this build's ledger, reads the reference run's

# %% tags=["remove-input"]
ours, *quick = ledgers  # our run's ledger first, then the quick run's
ledger = ledgers[ours][1]
views = ledger_views(ledger, "Our run: each claim's 95% interval, the paper's value, the decision")
display(views["forest"])
display(views["verdicts"])
undecided = views["undecided"]
display(collapsed_frame(f"Undecided ({len(undecided)} claims): what these seeds could detect. Open to see them.", undecided))
display(collapsed_frame("Size and power of every claim. Open to see them.", views["power"]))

# %% tags=["remove-cell"]
from myst_nb import glue

from icil_paper.stats import Verdict

counts = views["counts"]
glue("ch00_claims", counts["claims"])
glue("ch00_decided", counts["decided"])
glue("ch00_holds", counts["counts"][Verdict.HOLDS])
glue("ch00_not_hold", counts["counts"][Verdict.DOES_NOT_HOLD])
glue("ch00_smaller", counts["size_excluded"])
glue("ch00_larger", counts["size_larger"])
glue("ch00_undecided", counts["undecided"])
glue("ch00_decidable", counts["decidable_with_10_seeds"])

# %% [markdown]
# Claims: {glue:text}`ch00_claims`; decided under the pre-registered design:
# {glue:text}`ch00_decided`; decided smaller than the paper's effect:
# {glue:text}`ch00_smaller`, larger: {glue:text}`ch00_larger`. Undecided:
# {glue:text}`ch00_undecided`, of which {glue:text}`ch00_decidable` would detect the paper's
# effect with 10 or fewer seeds a row. Each row of the verdicts gives the seeds of each row
# it reads, the claim's row first. What the undecided claims would cost to decide on a
# cluster follows below the design.
#
# The quick run's ledger (CI's small preset: it tests the code, not the paper):

# %% tags=["remove-input", "hide-output"]
for source in quick:
    views = ledger_views(ledgers[source][1], "The quick run: 95% intervals, the paper's values, the decision")
    display(views["forest"])
    display(views["verdicts"])

# %% tags=["remove-cell"]
from icil_paper.book.report import question_answers, seeds_range

# What the introduction pastes: for each of Sec. IV's questions, the claim that carries it
# in our run (the committed reference records), its number, the paper's and the outcome.
for key, answer in question_answers(reference_ledger(ledgers)).items():
    for field, value in answer.items():
        glue(f"{key}_{field}", value)
glue("run_seeds", seeds_range())

# %% [markdown]
# ## How to read the ledger
#
# :::{dropdown} The unit, the rule, which verdict to quote, the two runs, what stands in for what (click to open)
# Every claim the paper makes in its experiments (Sec. IV), checked against our numbers.
# Each claim is written as a quantity with a direction: "LipVQ-VAE beats BC-Transformer by
# 5.3 points" is the difference of the two rows' average success, claimed above 0. The
# paper's value of that quantity is computed from its own tables; ours from our records,
# with a 95% interval.
#
# **The unit is the training seed.** Most of the variance of every comparison is the spread
# between training seeds, not the luck of the evaluation episodes. So an interval is built
# from each seed's value (its mean over tasks and episodes): Welch's t interval on the two
# rows' per-seed values when every seed plays the same scenes, a paired t interval when seed
# k of both rows plays its own scene set k (`icil_paper.stats` gives the method, its
# assumptions and its sources; `tests/test_verdicts.py` shows on simulated rows with no true
# difference that it decides at most about 5% of them).
#
# **The rule.** A claim *holds* when our whole interval lies on the claimed side of 0; it
# *does not hold* when the whole interval lies on the other side (we measured the
# opposite); it is *inconclusive* when the interval contains 0. A comparison that reads a
# row trained with a **single seed** is never decided (*too few seeds*): one seed cannot
# tell its luck from the method. "Best of k" claims hold only if the row beats each other
# row. *Not run* means a record the claim needs is missing.
#
# **Which verdict to quote.** The ledger tests some twenty claims at once; at 95% each, about
# one would be decided by chance alone. The column *decided* is the decision under the
# ledger's design: a claim's test must pass its level in a graph over its family (weighted
# Holm, 5% familywise; see the next section): **quote that one.** *Size* is a decision too:
# "smaller" or "larger than the paper's effect" when a repeated confidence interval at the
# claim's share of the 5% lies wholly on one side of the paper's value. *mde* is the smallest
# difference this design (these seeds and episodes) detects with 80% power at the level the
# claim must pass; *seeds needed* is the number of seeds a row that would detect the paper's
# effect with 80% power there ("—": more than 1000, or nothing to plan). Both come from the
# measured variance the claim's test reads: of the per-seed differences, for the paired
# claims.
# `icil-paper plan --preset reference` turns *seeds needed* into a run: the cells and
# CPU-hours each undecided claim would cost, and the command that computes exactly those
# cells on a Ray cluster (the README's "On a cluster").
#
# Two sources: **our run** (the `reference` preset, {glue:text}`run_seeds` seeds a row,
# results committed under `results/reference/`; tables name it "reference
# run") and **the quick run** (CI's small preset: it tests the code, not the paper; tables
# name it "this build"). The ledger of each is written to `results/<preset>/claims.json`.
# Our run's records were made under the design of the next two sections, fixed in the
# preset and committed before its first cell; every record names the commit it was made by.
# The records of the two earlier reference runs, on the robosuite kitchen suite that stood
# in for RoboCasa before Meta-World, are kept apart with their ledgers (the last sections of
# this chapter): read them as records of those protocols.
#
# **What stands in for what.** The paper's RoboCasa tables (I, III, IV, VI, VII, Fig. 5)
# run on Meta-World: a public benchmark, so anyone can set our numbers beside published
# ones, with a scripted expert for every task, so every policy trains on as many
# demonstrations per task as the paper's MimicGen data gives it. Thirteen Meta-World
# tasks stand for RoboCasa's seven skill families: pick and place is pick-place and
# pick-place-wall; doors door-open and door-close; drawers drawer-open and drawer-close;
# levers faucet-open and faucet-close (RoboCasa's levers are sink faucets); knobs dial-turn;
# insertion peg-insert-side and coffee-push (RoboCasa's insertion puts a mug under the
# coffee machine); buttons button-press and coffee-button. RoboCasa's human data set (Table
# VI) is the scripted experts driven through a model of a teleoperating person, on
# Meta-World scenes whose hand start is shifted and whose objects and goals lie in the
# outer 40% of each range; RoboCasa's zero-shot split (Table VII) is Meta-World's ML45 (45
# training tasks, five held out). The real Kinova arm (Table V) is robosuite's Kinova3 with
# perturbed dynamics and noisy observations, running policies trained on a simulated Panda;
# Table II runs on ManiSkill 3, as in the paper. The introduction says why each was chosen
# and what it changes. A claim that holds here holds for the stand-in, not for RoboCasa.
# :::

# %% [markdown]
# ## The primary family, declared before the data
#
# :::{dropdown} Which claims carry Q1-Q3, and how the 5% is shared (click to open)
# Which claims carry the paper's three questions was decided from the paper's text alone,
# before any new record (`icil_paper.config.PRIMARY_CLAIMS`): the abstract's "improves
# performance by more than 5.3%" and the conclusion's "outperforms state-of-the-art
# baselines on RoboCasa and ManiSkill" (Q1: LipVQ-VAE against BC-Transformer and against
# ACT), "improves smoothness over other tokenizers" and the Lipschitz condition "leading to
# improved robotic manipulation performance" (Q2: the smoothest latents; Eq. 4 on VQ-VAE),
# and the real robot's "smoother, more reliable trajectories" (Q3: Table V's motion and
# success). These six share 80% of the familywise 5%, every other testable claim 20%, and a
# decided claim passes its share to the others (weighted Holm's graph, Bretz et al. 2009).
# The rank correlations are descriptive: read from a bootstrap across six rows, they decide
# nothing. A reference ledger read from records gathered under the older design (one family,
# Holm over every claim) is labelled as that design's record, and the design above decides
# nothing on it.
# :::

# %% [markdown]
# ## How our run was designed
#
# :::{dropdown} How the seeds were allocated in stages (click to open)
# The reference run allocates its seeds in stages (the paragraph under the table, from
# `icil_paper.planning.design` and `icil_paper.planning.staged`): every row a claim reads
# starts at 5 seeds, and after each look only the rows of claims still undecided whose
# conditional power at the observed effect is at least 0.1 and whose next stage fits the
# run's budget go on (the older design's run: those a later stage could decide at the
# paper's effect); each look's seeds per row are written to `results/reference/design.json`.
# Below, per claim: the seeds a row its power analysis asks for the paper's effect
# (*seeds needed*), the records those variances came from (while this run's own ledger
# has none, the older code's), the fewest seeds one of its rows has at the stage the run has reached
# (*stage*) and the fewest of them one of its rows has finished (*finished*: the ledger
# reads the claim once this reaches *stage*), and the 95% half-width of the difference
# expected at the stage's seeds. The episodes per task of each suite follow from the split
# of each class of claim's paired variance into its seed and episode parts
# (`planning.design.episode_design`, `stats.episodes_per_seed`); the `reference` preset's
# docstring gives that arithmetic and the run's estimated cost.
# :::

# %% tags=["remove-input", "hide-output"]
display(design_frame(as_run(get_preset(REFERENCE))))

# %% tags=["remove-cell"]
from icil_paper import stats

tables = get_preset(REFERENCE).tables
design = stats.SequentialDesign(tables.seed_stages)
glue("ch00_stages", ", ".join(map(str, design.stages)))
glue("ch00_levels", ", ".join(f"{p:.3g}" for p in design.nominal_levels()))
glue("ch00_primary_n", len(tables.primary_claims))
glue("ch00_primary_share", f"{tables.family_weights[0]:.0%}")
glue("ch00_other_share", f"{tables.family_weights[1]:.0%}")
glue("ch00_continuation", f"{tables.continuation_power:g}")
glue("ch00_budget", f"{tables.stage_budget_hours:g}" if tables.stage_budget_hours else "no")

# %% tags=["remove-cell"]
looks = stage_counts(reference_ledger(ledgers))
glue("ch00_look_decided", looks["decided"])
glue("ch00_look_claims", looks["claims"])
glue("ch00_look_going", len(looks["going"]))
glue("ch00_look_going_ids", ", ".join(looks["going"]) or "none")
glue("ch00_look_stopped", looks["stopped"])
glue("ch00_look_budget", looks["by_budget"])
glue("ch00_look_unlooked", looks["unlooked"])

# %% tags=["remove-cell"]
store = ResultsStore(REFERENCE).dir
rates = {"now": decision_rate(store),
         **{f"earlier{k}": decision_rate(store / run.folder) for k, run in enumerate(EARLIER_RUNS)}}
for name, rate in rates.items():
    decided, hours = rate[:2] if rate else (0, 0.0)
    glue(f"ch00_rate_{name}_decided", decided)
    glue(f"ch00_rate_{name}_hours", f"{hours:.1f}")
    glue(f"ch00_rate_{name}_per10", f"{10 * decided / hours:.1f}" if hours else "—")
progress = run_progress() or {"finished": 0, "planned": 0, "hours": 0.0, "sittings": 0,
                              "wall_hours": None, "target_hours": None, "commits": []}
glue("ch00_cells_done", progress["finished"])
glue("ch00_cells_planned", progress["planned"])
glue("ch00_machine_hours", f"{progress['hours']:.1f}")
glue("ch00_sittings", progress["sittings"])
glue("ch00_wall_at_2", f"{progress['wall_hours']:.1f}" if progress["wall_hours"] else "—")
glue("ch00_target_hours", f"{progress['target_hours']:g}" if progress["target_hours"] else "no")
glue("ch00_run_commits", ", ".join(progress["commits"]) or "none")

# %% [markdown]
# Seeds are allocated in stages: looks at {glue:text}`ch00_stages` seeds a row, with
# O'Brien-Fleming-type alpha spending (Lan and DeMets 1983): at a level of 5% a look decides
# when its t-test p-value is at most {glue:text}`ch00_levels`. Each claim's p-value is the
# design's repeated p-value, the smallest level at whose boundary one of its looks so far
# would have decided it (Jennison and Turnbull 2000, Sec. 9.1). The
# {glue:text}`ch00_primary_n` claims of the primary family share
# {glue:text}`ch00_primary_share` of the familywise 5% and every other testable claim the
# remaining {glue:text}`ch00_other_share`; a decided claim passes its share on to the others
# (weighted Holm's graph, Bretz et al. 2009), at every look, so a claim decided early stays
# decided and the familywise level holds whichever rows go on (Maurer and Bretz 2013).
# After a look, the rows of an undecided claim go on to the next stage while its
# conditional power at the observed effect, to cross the last boundary at its current
# level, is at least {glue:text}`ch00_continuation`: the rule is non-binding, so it costs
# no error. The run has a budget of {glue:text}`ch00_budget` hours at two cells at a time,
# as the benchmark rates project them: after a look the claims that may go on are taken
# cheapest first while the whole run stays within it, and the others stop too. Stopping a
# claim can only lower its chance of a wrong decision.
#
# The committed ledger's looks, of its {glue:text}`ch00_look_claims` claims: decided at a
# look, {glue:text}`ch00_look_decided`; undecided and going on to the next stage,
# {glue:text}`ch00_look_going` ({glue:text}`ch00_look_going_ids`); stopped undecided,
# {glue:text}`ch00_look_stopped` ({glue:text}`ch00_look_budget` of them at the budget); no
# look yet (a row they read has not finished its stage), {glue:text}`ch00_look_unlooked`.
#
# Each look, from the run's design record (`results/reference/design.json`): the seeds a
# row had at it, the rows it read with the seeds they had realised, and the rows it sent on:

# %% tags=["remove-input"]
display(looks_frame(read_record(ResultsStore(REFERENCE))))

# %% [markdown]
# What the run cost, from `results/reference/cost.json`: {glue:text}`ch00_cells_done` of
# {glue:text}`ch00_cells_planned` planned cells finished, from commit
# {glue:text}`ch00_run_commits`, in {glue:text}`ch00_machine_hours` hours of machine time
# over {glue:text}`ch00_sittings` sittings (the run was stopped between sittings and resumed
# from its last checkpoints). From the cells' own CPU times, the whole run takes
# {glue:text}`ch00_wall_at_2` hours at two cells at a time on an idle 2-core machine,
# against a budget of {glue:text}`ch00_target_hours` hours. Claims decided per CPU-hour:
# this run, {glue:text}`ch00_rate_now_decided` for {glue:text}`ch00_rate_now_hours`
# CPU-hours ({glue:text}`ch00_rate_now_per10` per 10 CPU-hours); the kitchen run before it,
# {glue:text}`ch00_rate_earlier0_decided` for {glue:text}`ch00_rate_earlier0_hours`
# CPU-hours ({glue:text}`ch00_rate_earlier0_per10` per 10); the older protocol's run,
# {glue:text}`ch00_rate_earlier1_decided` for {glue:text}`ch00_rate_earlier1_hours`
# CPU-hours ({glue:text}`ch00_rate_earlier1_per10` per 10).
#
# What deciding the undecided claims would take on a cluster, from `icil-paper plan
# --preset reference` (`results/reference/plan.json`): the seeds a row each claim needs to
# detect the paper's effect with 80% power, the cells the run lacks for it and their CPU
# time at the run's own CPU time per cell. Of the {glue:text}`ch00_plan_undecided` undecided
# claims, the {glue:text}`ch00_plan_planned` that a preset's data sets can decide take
# {glue:text}`ch00_plan_cells` cells, {glue:text}`ch00_plan_cpu_hours` CPU-hours, or
# {glue:text}`ch00_plan_wall_hours` hours at {glue:text}`ch00_plan_cores` cores.

# %% tags=["remove-input"]
plan_rows, plan_totals = plan_frame(store)
for name, value in plan_totals.items():
    glue(f"ch00_plan_{name}", value, display=False)
display(collapsed_frame("The plan for each undecided claim. Open to see it.", plan_rows))

# %% [markdown]
# ## What each claim compares

# %% tags=["remove-input", "hide-output"]
display(ledger_frame(reference_ledger(ledgers), "details"))

# %% [markdown]
# ## What the earlier runs said
#
# Two reference runs came before this one, both on the robosuite kitchen suite that stood in
# for RoboCasa before Meta-World. Their ledgers are kept as those protocols' records, each
# with the commit of the code that computed it; the collapsed table sets their decisions
# beside this run's, claim by claim. Read the earlier columns as what those protocols said,
# not as results of this one: their regime starved the baselines that do not learn in
# context and left the kitchen's pick and place at 0.

# %% tags=["remove-cell"]
older = {run.name: older_ledger(REFERENCE, run.folder) for run in EARLIER_RUNS}
for k, kept in enumerate(older.values()):
    glue(f"ch00_earlier{k}_commit", kept[0]["commit"][:7] if kept else "none")

# %% [markdown]
# The kitchen run (its ledger computed by commit {glue:text}`ch00_earlier0_commit`) played
# the robosuite kitchen suite with 3 demonstrations a task and decided under Holm's
# correction over every claim alike. The older protocol's run (commit
# {glue:text}`ch00_earlier1_commit`) played the same suite with baselines that did not read
# the task's instruction and one demonstration set for every training seed.

# %% tags=["remove-input"]
display(collapsed_frame("What each earlier run said, claim by claim. Open to see it.",
                        earlier_verdicts(reference_ledger(ledgers))))

# %% [markdown]
# ## Reference records made by older code
#
# :::{dropdown} Why these records are listed apart (click to open)
# A committed reference record whose key the current code no longer computes (a config or
# a definition changed since it was run; for the records made on the kitchen suite, the
# suite itself) is not used above; it is listed here until
# `icil-paper tables --preset reference --retire-stale` moves it out of the store, beside
# the older ledgers, and nothing is deleted.
# :::

# %% tags=["remove-cell"]
stale = stale_records(REFERENCE)
freshness = reference_freshness(REFERENCE)
retired = retired_records(REFERENCE)
glue("stale_n", freshness["stale"])
glue("records_n", freshness["records"])
glue("retired_n", sum(retired.values()))

# %% [markdown]
# Of the {glue:text}`records_n` committed reference records, {glue:text}`stale_n` are stale
# and not used above; {glue:text}`retired_n` more, made by older versions of the code, were
# moved out of the store to `results/reference/older-code/records/`, each counted by the
# commit that made it. The earlier runs' ledgers follow, collapsed, each labelled with its
# commit.

# %% tags=["remove-input", "hide-output"]
print("stale records:", ", ".join(stale) or "none")
for name, kept in older.items():
    if kept is not None:
        print(f"{name}, ledger computed by commit {kept[0]['commit'][:7]}:")
        display(ledger_frame(kept[1], "verdicts"))
