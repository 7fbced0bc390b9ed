"""The words the book prints for a verdict: one table per kind of sentence, keyed by
`stats.Verdict`. No other module spells a verdict (`tests/test_vocabulary.py` scans the
sources for one).

    from icil_paper.stats import Size, Verdict
    from icil_paper.verdict_words import SMOOTHER, claim_words
    SMOOTHER[Verdict.HOLDS]                    # "smoother"
    claim_words(Verdict.HOLDS, side="above")   # "holds: our interval lies above 0"

A verdict is read on a claimed direction; each table below names the claim it reads (a
least-energy difference claimed lower, a success difference claimed higher, ...).
"""

from __future__ import annotations

from icil_paper.stats import Size, Verdict

HOLDS, DOES_NOT_HOLD, INCONCLUSIVE, TOO_FEW_SEEDS, NOT_RUN = Verdict
DECIDED = (HOLDS, DOES_NOT_HOLD)
"""The verdicts that decide a claim, one way or the other."""
UNDECIDED = (INCONCLUSIVE, TOO_FEW_SEEDS)
"""The verdicts of a claim that was run and not decided."""
LEDGER_ORDER = (HOLDS, DOES_NOT_HOLD, INCONCLUSIVE, TOO_FEW_SEEDS, NOT_RUN)
"""The order in which counts of verdicts are listed."""

# --------------------------------------------------------------------------- claims ledger
_CLAIM = {
    HOLDS: "holds: our interval lies {side} 0",
    DOES_NOT_HOLD: "does not hold: our interval lies on the other side of 0",
    INCONCLUSIVE: "is inconclusive: our interval contains 0",
    TOO_FEW_SEEDS: "is not decided: a row it reads has a single training seed, so the spread "
                   "between seeds is unknown",
}


def claim_words(verdict: Verdict, side: str) -> str:
    """"the claim <words>" of a ledger entry; `side` is "above" or "below"."""
    return _CLAIM[Verdict(verdict)].format(side=side)


BEST_OF_K_INCONCLUSIVE = ("best of k: it holds only if every pairwise interval lies on the "
                          "claimed side, and does not hold only if one row beats it at the "
                          "Bonferroni level")
"""Why a best-of-k claim is inconclusive more often than a single difference."""

SIZE_SHORT = {Size.SMALLER: "smaller", Size.LARGER: "larger", Size.UNDECIDED: "undecided"}
"""A decided size (`stats.Size`, against the paper's effect) in a table's narrow column."""

COLOURS = {HOLDS: "#1a7f37", DOES_NOT_HOLD: "#cf222e", INCONCLUSIVE: "#9a6700",
           TOO_FEW_SEEDS: "#8c959f", NOT_RUN: "#d0d7de"}
"""The verdicts' colours in the forest plot (green, red, amber, grey, light grey)."""


def counted(verdict: Verdict, k: int) -> str:
    """"3 hold", "1 does not hold", ...: `k` claims with this verdict."""
    one = k == 1
    return {HOLDS: f"{k} {'holds' if one else 'hold'}",
            DOES_NOT_HOLD: f"{k} {'does' if one else 'do'} not hold",
            INCONCLUSIVE: f"{k} {'is' if one else 'are'} inconclusive",
            TOO_FEW_SEEDS: f"{k} {'reads' if one else 'read'} a row with a single training "
                           "seed (too few seeds)",
            NOT_RUN: f"{k} {'is' if one else 'are'} not run yet"}[Verdict(verdict)]


# --------------------------------------------------------------------------- tables' sentences
SMOOTHER = {HOLDS: "smoother", DOES_NOT_HOLD: "less smooth",
            INCONCLUSIVE: "not distinguishable (the interval contains 0)",
            TOO_FEW_SEEDS: "not decided (a single training seed)"}
"""A least-energy difference (claimed: lower, the first row smoother) in words."""

def _finding(more: str, less: str, what: str) -> dict[Verdict, str]:
    return {HOLDS: more, DOES_NOT_HOLD: less, INCONCLUSIVE: f"not measurably different in {what}",
            TOO_FEW_SEEDS: f"undecided in {what} (too few seeds)", NOT_RUN: f"not yet measured in {what}"}


ANALYSIS_SMOOTH = _finding("smoother", "less smooth", "smoothness")
"""The analysis table's smoothness finding (claimed: the variant is smoother)."""

ANALYSIS_SUCCESS = _finding("more successful", "less successful", "success")
"""The analysis table's success finding (claimed: the variant succeeds more)."""

EXPLANATION = {HOLDS: "survives", DOES_NOT_HOLD: "does not survive",
               INCONCLUSIVE: "cannot be decided at this number of seeds and episodes",
               TOO_FEW_SEEDS: "cannot be decided (a row has one seed)", NOT_RUN: "has not run yet"}
"""The smoothness explanation's verdict (chapter 11)."""

OUTCOME = {HOLDS: "higher", DOES_NOT_HOLD: "lower",
           INCONCLUSIVE: "no difference detected (the interval contains 0)",
           TOO_FEW_SEEDS: "not decided (a row has a single training seed)",
           NOT_RUN: "not run yet"}
"""A two-sided question read as "the variant succeeds more" (the official code's table)."""

TRAINING_WINDOW = {HOLDS: "holds", DOES_NOT_HOLD: "does not hold (windows do better)",
                   INCONCLUSIVE: "is inconclusive (the interval contains 0)",
                   TOO_FEW_SEEDS: "is not decided: one training seed cannot tell its luck "
                                  "from the method (too few seeds)"}
"""Chapter 02's "that whole episodes help <words>"."""

DESIGN_OUTCOME = {HOLDS: "decided: it holds", DOES_NOT_HOLD: "decided: it does not hold",
                  INCONCLUSIVE: "undecided", TOO_FEW_SEEDS: "undecided (a row has one seed)",
                  NOT_RUN: "not run yet"}
"""The design's outcome for a claim (its verdict after Holm), as the introduction quotes it."""

SMALLER_THAN_PAPER = "decided: smaller than the paper's effect"
"""The outcome of a claim whose size was decided below the paper's effect (`Size.SMALLER`)."""

SEEDS_TO_DECIDE = "about {n} seeds a row would decide it"
"""What an undecided claim would take: the seeds a row its power analysis asks for."""
ALONE_BUT_NOT_TOGETHER = {
    HOLDS: "its 95% interval alone lies on the claimed side of 0, but not at the stricter "
           "level that testing every claim at once requires",
    DOES_NOT_HOLD: "its 95% interval alone lies on the other side of 0, but not at the "
                   "stricter level that testing every claim at once requires"}
"""Why a claim whose interval excludes 0 is still undecided (keyed by its unadjusted verdict)."""

MISSING = NOT_RUN.value
"""What a table cell or a finding shows while a record it reads is missing."""


def answer(verdicts) -> str:
    """A question's answer from the verdicts (after Holm) of the claims that decide it: "Yes",
    "No", "In part (...)", "Not decided at this scale" or "Not run yet"."""
    verdicts = [Verdict(v) for v in verdicts]
    run = [v for v in verdicts if v != NOT_RUN]
    if not run:
        return "Not run yet"
    decided = [v for v in run if v in DECIDED]
    if decided and len(decided) == len(run) and len(set(decided)) == 1:
        return "Yes" if decided[0] == HOLDS else "No"
    if decided:
        return "In part (" + ", ".join(counted(v, verdicts.count(v)) for v in LEDGER_ORDER
                                       if v in verdicts) + ")"
    return "Not decided at this scale"

QUICK_RUN_OPEN = "The quick run ({preset} preset: it tests the code, not the paper). Open to see it."
"""The label of a collapsed block holding the quick run's numbers beside our run's."""
PER_SEED_OPEN = "codebook use of each training seed ({rows} rows). Open to see it."
"""The label of a collapsed block holding one source's codebook use, a row per seed."""

DESCRIPTIVE_WHY = {
    "correlation": "a rank correlation across rows, read from a joint bootstrap: described, "
                   "not tested",
    "floor": "its smallest attainable p-value ({floor:.2g}) cannot pass its first step "
             "({level:.2g})"}
"""Why a claim of the ledger decides nothing (`tables.design.ledger_design` stores it)."""
