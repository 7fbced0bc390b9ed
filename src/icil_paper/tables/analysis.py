"""Is it smoothness? The analysis of the paper's explanation (the analysis chapter).

The paper explains LipVQ-VAE's success by smoothness: Eq. 4 bounds the encoder's Lipschitz
constant, so neighbouring actions get neighbouring latents, so latent trajectories are
smoother (a lower least energy), and smoother tokens make in-context imitation succeed more.
Each link can be checked on the `analysis` table's cells:

1. Does Eq. 4 bind? The share of rows whose absolute sum the trained bound caps, the
   product of the layer bounds and the encoder's empirical Lipschitz constant.
2. Is LipVQ-VAE smoother than VQ-VAE once the latent scale is removed? The raw least energy
   grows with the square of the latent scale; the standardized one does not.
3. Does LipVQ-VAE succeed more than VQ-VAE, and do the variants in which Eq. 4 binds
   (gamma = 1, initial bounds of 1) or in which codebook collapse is remedied (dead-code
   restart) change smoothness and success the way the explanation predicts?

`findings` turns each comparison into an estimate with its interval and a verdict
(`icil_paper.stats`); `conclusion` combines them into the chapter's closing sentence. No
sentence about results is written by hand.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from icil_paper import stats
from icil_paper.tables.assemble import TableResult

PAPER = "icrt+lipvq (paper)"
VQ = "icrt+vq"


def _features(result: TableResult, row: str):
    cell = result.cell(row, "features")
    return cell if cell is not None and cell.estimate is not None else None


def _mean_metric(cell, key: str) -> float | None:
    values = [m.get(key) for m in cell.extra["metrics"]]
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None


def analysis_frame(result: TableResult, digits: int = 2):
    """One row per variant: success, raw and standardized least energy (with 95% intervals),
    latent scale sigma, codes used, share of encoder rows Eq. 4 caps, product of the bounds
    and the empirical Lipschitz constant (means over seeds; "-" where it does not apply)."""
    import pandas as pd

    from icil_paper.tables.assemble import format_cell, unbroken

    def number(value, percent=False):
        if value is None:
            return "-"
        return f"{100 * value:.0f}%" if percent else _short(value)

    out = []
    for row in result.spec.rows:
        feat = _features(result, row.label)
        line: dict[str, Any] = {"": row.label,
                                "success": unbroken(format_cell(result.cell(row.label, "avg"),
                                                                digits))}
        if feat is None:
            line["least energy"] = "not run"
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
    """Three significant digits without an exponent up to 10^6 (6180, not 6.18e+03), so
    that the analysis table's columns stay narrow."""
    return f"{value:.0f}" if 1e3 <= abs(value) < 1e6 else f"{value:.3g}"


def _success_diff(result: TableResult, a: str, b: str):
    xa, xb = result.outcomes(a, "avg"), result.outcomes(b, "avg")
    return None if xa is None or xb is None else stats.paired_difference(xa, xb)


def _smooth_diff(result: TableResult, a: str, b: str, standardized: bool = True):
    fa, fb = _features(result, a), _features(result, b)
    if fa is None or fb is None:
        return None
    key = "standardized" if standardized else None
    xa = fa.extra[key] if key else fa.data
    xb = fb.extra[key] if key else fb.data
    return stats.paired_score_difference(xa, xb)


def findings(result: TableResult) -> list[dict[str, Any]]:
    """The comparisons of the module docstring: quantity, claimed direction, estimate,
    verdict, and `variant`: the variant row a success comparison tests against its base
    (None for the other comparisons)."""
    rows = [r.label for r in result.spec.rows]
    comparisons = [
        ("LipVQ-VAE's standardized least energy minus VQ-VAE's", -1,
         _smooth_diff(result, PAPER, VQ), None),
        ("LipVQ-VAE's raw least energy minus VQ-VAE's", -1,
         _smooth_diff(result, PAPER, VQ, standardized=False), None),
        ("LipVQ-VAE's success minus VQ-VAE's", +1, _success_diff(result, PAPER, VQ), None),
    ]
    for row in rows:
        if row in (PAPER, VQ):
            continue
        base = VQ if row.startswith("vq") else PAPER
        comparisons.append((f"'{row}' success minus '{base}'", +1,
                            _success_diff(result, row, base), row))
        if "restart" not in row and "windows" not in row:
            comparisons.append((f"'{row}' standardized least energy minus '{base}'", -1,
                                _smooth_diff(result, row, base), None))
    out = []
    for quantity, direction, est, variant in comparisons:
        out.append({"quantity": quantity, "direction": direction, "variant": variant,
                    "estimate": est, "verdict": "not run" if est is None
                    else stats.verdict(est, direction=direction)})
    return out


def binding(result: TableResult) -> dict[str, float | None]:
    """Eq. 4 in the paper's LipVQ-VAE after training: share of rows capped, product of
    bounds, empirical Lipschitz constant (means over seeds; None while not run)."""
    feat = _features(result, PAPER)
    if feat is None:
        return {"capped_fraction": None, "bound_product": None, "empirical_lipschitz": None}
    return {k: _mean_metric(feat, k)
            for k in ("capped_fraction", "bound_product", "empirical_lipschitz")}


def conclusion(result: TableResult) -> str:
    """The closing sentence, from the numbers: the explanation survives when LipVQ-VAE is
    both smoother on the standardized score and more successful than VQ-VAE; it fails when
    either is measured the other way; otherwise the data cannot tell."""
    found = {f["quantity"]: f for f in findings(result)}
    smoother = found["LipVQ-VAE's standardized least energy minus VQ-VAE's"]["verdict"]
    better = found["LipVQ-VAE's success minus VQ-VAE's"]["verdict"]
    b = binding(result)
    if smoother == "not run" or better == "not run":
        return "The analysis cells have not run yet."
    bind = ("" if b["capped_fraction"] is None else
            f"In the paper's LipVQ-VAE, Eq. 4 caps {100 * b['capped_fraction']:.0f}% of the "
            f"encoder's rows after training (product of bounds {b['bound_product']:.3g}, "
            f"empirical Lipschitz constant {b['empirical_lipschitz']:.3g}). ")
    if smoother == "holds" and better == "holds":
        verdict = ("the smoothness explanation survives: once the latent scale is removed "
                   "LipVQ-VAE is smoother than VQ-VAE, and it succeeds more")
    elif "does not hold" in (smoother, better):
        what = [name for name, v in (("smoother (standardized)", smoother),
                                     ("more successful", better)) if v == "does not hold"]
        verdict = ("the smoothness explanation does not survive: LipVQ-VAE was measured "
                   f"not {' and not '.join(what)} than VQ-VAE")
    else:
        verdict = ("the data cannot decide the smoothness explanation: LipVQ-VAE's standardized "
                   f"smoothness is {smoother} and its success advantage {better} against "
                   "VQ-VAE at this number of seeds and episodes")
    return f"{bind}In this run, {verdict}.{_variant_effects(found.values())}"


def _variant_effects(found) -> str:
    """A sentence naming every variant whose success interval against its base excludes 0,
    largest effect first ('' when none does)."""
    moved = sorted((f for f in found if f["variant"] is not None
                    and f["verdict"] in ("holds", "does not hold")),
                   key=lambda f: -abs(f["estimate"].value))
    if not moved:
        return ""
    parts = [f"{f['quantity'].replace(' success minus ', ' against ')} "
             f"{f['estimate'].value:+.2f} [{f['estimate'].low:+.2f}, {f['estimate'].high:+.2f}]"
             for f in moved]
    return (" The variants whose success interval excludes 0 (success difference, 95% "
            f"interval): {'; '.join(parts)}.")
