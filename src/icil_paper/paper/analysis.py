"""The analysis table (our own): is it smoothness? The paper's explanation checked, chapter 11.

    spec(preset)                 # ICRT with VQ-VAE, LipVQ-VAE and their variants x avg, features
    analysis_frame(result)       # success, least energy (raw, standardized), scale, Eq. 4's facts
    binding_frame(result)        # does Eq. 4 bind, and how far the bounds could move
    effects_frame(result)        # each variant against its base, in the vocabulary's words
    explanation_verdict(result)  # the smoothness explanation's verdict
    training_windows(result)     # chapter 02: whole episodes against 32-step windows

The paper's explanation: Eq. 4 bounds the encoder's Lipschitz constant, so latents are
smoother, so ICRT succeeds more. Each link is checked on the table's entries: does Eq. 4 bind,
is LipVQ-VAE smoother once the latent scale is removed, and does each variant move
smoothness and success together.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from icil_paper import config, stats, verdict_words
from icil_paper.config import Preset
from icil_paper.stats import Verdict
from icil_paper.tables.assemble import TableResult, format_difference, format_entry, unbroken
from icil_paper.tables.definitions import (
    features_entry,
    row_seeds,
    seed_runs,
    table_i_seeds,
    tasks_entry,
)
from icil_paper.tables.spec import Row, TableSpec

ANALYSIS_VARIANTS = (
    ("icrt+vq", "vq", {}),
    ("icrt+lipvq (paper)", "lipvq", {}),
    ("gamma = 1", "lipvq", {"lipschitz": {"weight": 1.0}}),
    ("c_l init 1", "lipvq", {"lipschitz": {"c_init": 1.0}}),
    ("c_l at the shared rate", "lipvq", {"lipschitz": {"c_lr_scale": 1.0}}),
    ("Liu et al. init", "lipvq", {"lipschitz": {"weight_init": "liu"}}),
    ("vq + dead-code restart", "vq", {"dead_code_restart": 100}),
    ("lipvq + dead-code restart", "lipvq", {"dead_code_restart": 100}),
    ("lipvq, 32-step random windows", "lipvq", {"_policy": {"query_len": 32,
                                                           "query_start": "random"}}),
)
"""The analysis table's rows: (label, tokenizer, changes to its config; `_policy`: to
ICRT's)."""


def _variant(preset: Preset, tokenizer: str, changes: dict) -> tuple:
    changes = dict(changes)
    policy = dataclasses.replace(preset.policies.icrt, **changes.pop("_policy", {}))
    tok = preset.tokenizers.get(tokenizer)
    if "lipschitz" in changes:
        changes["lipschitz"] = dataclasses.replace(tok.lipschitz, **changes["lipschitz"])
    return policy, dataclasses.replace(tok, **changes)


def spec(preset: Preset) -> TableSpec:
    """The analysis table: each of `ANALYSIS_VARIANTS` x avg success and features."""
    tasks = preset.data.robocasa_tasks
    rows = []
    for name, tokenizer, changes in ANALYSIS_VARIANTS:
        policy, tok = _variant(preset, tokenizer, changes)
        seeds = row_seeds(preset, "analysis", name, preset.tables.icrt_seeds)
        if not changes:  # Table I's runs
            seeds = max(seeds, table_i_seeds(preset, "icrt", tokenizer))
        runs = [r.replace(policy=policy) for r in seed_runs(preset, "icrt", tok, tasks, seeds)]
        rows.append(Row(name, {"avg": tasks_entry(preset, runs, tasks),
                               "features": features_entry(preset, runs)}))
    return TableSpec("analysis", "Is it smoothness? Lipschitz bound, latent scale and collapse",
                     ("avg", "features"), tuple(rows), note=(
                         "ICRT with VQ-VAE and LipVQ-VAE variants on Table I's Meta-World tasks; "
                         "`features` holds each trained encoder's least energy (raw and "
                         "standardized), latent scale, codes used and Lipschitz facts."))


# --------------------------------------------------------------------------- the findings
PAPER = "icrt+lipvq (paper)"
VQ = "icrt+vq"


def _mean_metric(entry, key: str) -> float | None:
    values = [m.get(key) for m in entry.extra["metrics"]]
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None


def analysis_frame(result: TableResult, digits: int = 2):
    """One row per variant: success, least energy (raw, standardized), sigma, codes used and
    Eq. 4's facts (means over seeds; "-" where it does not apply)."""
    import pandas as pd

    def number(value, percent=False):
        if value is None:
            return "-"
        return f"{100 * value:.0f}%" if percent else _short(value)

    out = []
    for row in result.spec.rows:
        feat = result.features(row.label)
        line: dict[str, Any] = {"": row.label,
                                "success": unbroken(format_entry(result.entry(row.label, "avg"),
                                                                digits))}
        if feat is None:
            line["least energy"] = verdict_words.MISSING
        else:
            std = feat.extra["standardized_estimate"]
            line.update({
                "least energy": number(feat.estimate.value),
                "standardized": unbroken(f"{_short(std.value)} [{_short(std.low)}, "
                                         f"{_short(std.high)}]"),
                "σ": number(float(np.mean(feat.extra["latent_scale"]))),
                "codes": number(_mean_metric(feat, "codes_used")),
                "rows capped": number(_mean_metric(feat, "capped_fraction"), percent=True),
                "∏ bounds": number(_mean_metric(feat, "bound_product")),
                "empirical Lip.": number(_mean_metric(feat, "empirical_lipschitz")),
            })
        out.append(line)
    return pd.DataFrame(out).set_index("")


def _short(value: float) -> str:
    """Three significant digits without an exponent up to 10^6 (6180, not 6.18e+03)."""
    return f"{value:.0f}" if 1e3 <= abs(value) < 1e6 else f"{value:.3g}"


def _success_diff(result: TableResult, a: str, b: str):
    xa, xb = result.outcomes(a, "avg"), result.outcomes(b, "avg")
    return None if xa is None or xb is None else stats.paired_difference(xa, xb)


def _smooth_diff(result: TableResult, a: str, b: str, standardized: bool = True):
    fa, fb = result.features(a), result.features(b)
    if fa is None or fb is None:
        return None
    return stats.paired_score_difference(*(f.extra["standardized"] if standardized else f.data
                                           for f in (fa, fb)))


SMOOTHER = -1
"""The direction "smoother" of a least-energy difference (lower is smoother)."""
MORE_SUCCESSFUL = +1
"""The direction "more successful" of a success difference."""

BINDS_AT = 0.25
"""Eq. 4 *binds* in a row when at least this share of its encoder's rows (all Lipschitz
layers, mean over seeds) is capped after training."""


def _base(row: str) -> str:
    """The row a variant is compared with: VQ-VAE's for VQ variants, else the paper's."""
    return VQ if row.startswith("vq") else PAPER


def findings(result: TableResult) -> list[dict[str, Any]]:
    """Each comparison: quantity, direction, estimate, verdict, `kind` ("success",
    "smoothness" or "raw smoothness"), `row`, `base` and `variant` (None for LipVQ-VAE
    against VQ-VAE); every variant against its base in success and smoothness."""
    rows = [r.label for r in result.spec.rows]
    comparisons = [
        ("LipVQ-VAE's standardized least energy minus VQ-VAE's", SMOOTHER,
         _smooth_diff(result, PAPER, VQ), PAPER, VQ, "smoothness"),
        ("LipVQ-VAE's raw least energy minus VQ-VAE's", SMOOTHER,
         _smooth_diff(result, PAPER, VQ, standardized=False), PAPER, VQ, "raw smoothness"),
        ("LipVQ-VAE's success minus VQ-VAE's", MORE_SUCCESSFUL,
         _success_diff(result, PAPER, VQ), PAPER, VQ, "success"),
    ]
    for row in rows:
        if row in (PAPER, VQ):
            continue
        base = _base(row)
        comparisons.append((f"'{row}' success minus '{base}'", MORE_SUCCESSFUL,
                            _success_diff(result, row, base), row, base, "success"))
        comparisons.append((f"'{row}' standardized least energy minus '{base}'", SMOOTHER,
                            _smooth_diff(result, row, base), row, base, "smoothness"))
    return [{"quantity": quantity, "direction": direction, "kind": kind, "row": row,
             "base": base, "variant": None if row == PAPER else row, "estimate": est,
             "verdict": Verdict.NOT_RUN if est is None else stats.verdict(est, direction=direction)}
            for quantity, direction, est, row, base, kind in comparisons]


def _fact(result: TableResult, row: str, key: str) -> float | None:
    feat = result.features(row)
    return None if feat is None else _mean_metric(feat, key)


def _lipschitz_row(row) -> bool:
    """Whether a row's encoder has Lipschitz layers (read from its RunSpec's tokenizer)."""
    entry = row.entries.get("features")
    tok = entry.units[0].run.tokenizer if entry is not None and entry.units else None
    return (tok is not None and hasattr(tok, "lipschitz")
            and getattr(tok, "norm", "lipschitz") in ("lipschitz", "lipschitz-last"))


def capped_shares(result: TableResult) -> dict[str, float | None]:
    """{Lipschitz row: share of its encoder's rows Eq. 4 caps, mean over seeds, or None}."""
    return {row.label: _fact(result, row.label, "capped_fraction")
            for row in result.spec.rows if _lipschitz_row(row)}


def binding_rows(result: TableResult, threshold: float = BINDS_AT) -> list[str]:
    """The rows in which Eq. 4 binds: a capped share of at least `threshold` (`BINDS_AT`)."""
    return [row for row, share in capped_shares(result).items()
            if share is not None and share >= threshold]


def bound_travel(result: TableResult) -> dict[str, float]:
    """{Lipschitz row: the most a bound c_l can move in training (`config.bound_travel`)}."""
    runs = {row.label: row.entries["features"].units[0].run
            for row in result.spec.rows if _lipschitz_row(row)}
    return {label: config.bound_travel(run.train, run.tokenizer.lipschitz.c_lr_scale)
            for label, run in runs.items()}


def bound_travel_frame():
    """How far a bound c_l can travel (`config.bound_travel`) in the paper's run and each
    preset's, at the shared rate and at the preset's `c_lr_scale`."""
    import pandas as pd

    paper = config.bound_travel(config.PAPER_TRAIN)
    rows = [("the paper (500K iterations)", config.PAPER_TRAIN, 1.0)]
    rows += [(f"`{name}` preset", p.train, p.tokenizers.lipvq.lipschitz.c_lr_scale)
             for name in config.PRESET_NAMES for p in [config.get_preset(name)]]
    return pd.DataFrame([{
        "": label, "steps": train.steps, "warm-up": train.warmup_steps, "lr": train.lr,
        "sum of schedule factors": config.schedule_sum(train.warmup_steps, train.steps),
        "travel at the shared rate": config.bound_travel(train),
        "c_lr_scale": scale, "travel": config.bound_travel(train, scale),
        "travel / paper's": config.bound_travel(train, scale) / paper}
        for label, train, scale in rows]).set_index("")


def binding_frame(result: TableResult, threshold: float = BINDS_AT):
    """Does Eq. 4 bind? Per Lipschitz row: share of rows capped, whether it reaches
    `threshold`, product of the bounds, `bound_travel` and the trained softplus(c_l)."""
    import pandas as pd

    travel = bound_travel(result)
    rows = {}
    for row, share in capped_shares(result).items():
        feat = result.features(row)
        bounds = [] if feat is None else [m.get("layer_bounds") for m in feat.extra["metrics"]]
        trained = (", ".join(_short(b) for b in np.mean(np.array(bounds, float), axis=0))
                   if bounds and all(b is not None for b in bounds) else verdict_words.MISSING)
        product = _fact(result, row, "bound_product")
        rows[row] = {"rows capped": verdict_words.MISSING if share is None else f"{share:.0%}",
                     f"binds (>= {threshold:.0%})": _yes_no(None if share is None
                                                            else share >= threshold),
                     "product of bounds": verdict_words.MISSING if product is None
                     else _short(product),
                     "most c_l can move": _short(travel[row]) if row in travel
                     else verdict_words.MISSING,
                     "trained softplus(c_l)": trained}
    return pd.DataFrame(rows).T


def _interval(est, digits: int) -> str:
    if est is None:
        return verdict_words.MISSING
    if digits:
        return format_difference(est, digits)
    return f"{_short(est.value)} [{_short(est.low)}, {_short(est.high)}]"


def variant_effects(result: TableResult) -> list[dict[str, Any]]:
    """Per variant: `variant`, `base`, its `smoothness` and `success` findings, and `binds`
    (None without Lipschitz layers or records)."""
    found = findings(result)
    shares = capped_shares(result)
    out = []
    for row in [r.label for r in result.spec.rows if r.label not in (PAPER, VQ)]:
        mine = {f["kind"]: f for f in found if f["variant"] == row}
        share = shares.get(row)
        out.append({"variant": row, "base": _base(row), "smoothness": mine["smoothness"],
                    "success": mine["success"],
                    "binds": None if share is None else share >= BINDS_AT})
    return out


def _yes_no(value: bool | None) -> str:
    """"yes", "no", or `verdict_words.MISSING` for None."""
    return verdict_words.MISSING if value is None else ("yes" if value else "no")


def explanation_verdict(result: TableResult) -> Verdict:
    """HOLDS when LipVQ-VAE is both smoother (standardized) and more successful than VQ-VAE,
    DOES_NOT_HOLD when either goes the other way, else NOT_RUN or INCONCLUSIVE."""
    found = {f["kind"]: Verdict(f["verdict"]) for f in findings(result) if f["variant"] is None}
    smoother, better = found["smoothness"], found["success"]
    if Verdict.NOT_RUN in (smoother, better):
        return Verdict.NOT_RUN
    if smoother == better == Verdict.HOLDS:
        return Verdict.HOLDS
    if Verdict.DOES_NOT_HOLD in (smoother, better):
        return Verdict.DOES_NOT_HOLD
    return Verdict.INCONCLUSIVE


def effects_frame(result: TableResult):
    """`variant_effects` as a table: differences with 95% intervals, in words, and binding."""
    import pandas as pd

    rows = {}
    for e in variant_effects(result):
        smooth, success = e["smoothness"], e["success"]
        rows[e["variant"]] = {
            "base": e["base"],
            "standardized least energy": _interval(smooth["estimate"], 0),
            "smoothness": verdict_words.ANALYSIS_SMOOTH[Verdict(smooth["verdict"])],
            "success": _interval(success["estimate"], 2),
            "success, in words": verdict_words.ANALYSIS_SUCCESS[Verdict(success["verdict"])],
            "Eq. 4 binds": _yes_no(e["binds"])}
    return pd.DataFrame(rows).T


# --------------------------------------------------------------------------- chapter 02's windows
WHOLE_EPISODES = PAPER
RANDOM_WINDOWS = "lipvq, 32-step random windows"
"""ICRT + LipVQ-VAE trained on whole episodes (the default) and on random 32-step windows."""


def training_windows(result: TableResult) -> dict[str, Any] | None:
    """Chapter 02's comparison: "whole", "windows", "difference" (whole minus windows),
    "verdict" and "seeds"; None while either row has not run."""
    a, b = result.outcomes(WHOLE_EPISODES), result.outcomes(RANDOM_WINDOWS)
    if a is None or b is None:
        return None
    diff = stats.paired_difference(a, b, scenes=result.scenes(WHOLE_EPISODES, RANDOM_WINDOWS))
    return {"whole": result.estimate(WHOLE_EPISODES), "windows": result.estimate(RANDOM_WINDOWS),
            "difference": diff, "verdict": stats.verdict(diff, direction=+1),
            "seeds": result.spec.row(WHOLE_EPISODES).entries["avg"].seeds}
