"""The paper against its official code: what each departure does to success, chapter 13.

    spec(preset)                 # the paper's LipVQ-VAE and Bin, the official code's, x families
    findings_frame(result)       # each variant against its base: difference, verdict, codes

The official code (`andvg3/LipVQ-VAE`) differs from the paper; each variant row is compared
with the paper's row it departs from (Table I's policies):

    variant                        base                  what differs
    icrt+lipvq (official code)     icrt+lipvq (paper)    every difference of `lipvq_official()`
    last layer only                icrt+lipvq (paper)    Eq. 4 on the last layer only (sigmoid,
                                                         per-row bounds), the rest the paper's
    detached latent                icrt+lipvq (paper)    the policy gets sg[z_q]
    no Lipschitz loss              icrt+lipvq (paper)    gamma = 0
    icrt+bin (official code)       icrt+bin (paper)      20 bins over the running min and max
    prompts from the minibatch     icrt+lipvq (paper)    training prompts of any task

The question is two-sided: "holds" reads higher, "does not hold" lower.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np

from icil_paper import stats, verdict_words
from icil_paper.config import Preset
from icil_paper.config_data import get_path, replace_path
from icil_paper.paper.table_i import TABLE_I_ROBOCASA
from icil_paper.stats import Verdict
from icil_paper.tables.assemble import TableResult, format_difference, format_entry, unbroken
from icil_paper.tables.definitions import (
    FAMILY_COLUMNS,
    family_entries,
    features_entry,
    label,
    row_seeds,
    seed_runs,
    table_i_seeds,
)
from icil_paper.tables.spec import Row, TableSpec
from icil_paper.tokenizers.configs import BinConfig, LipVQConfig, lipvq_official, official_bin

OFFICIAL_PAPER_LIPVQ = "icrt+lipvq (paper)"
OFFICIAL_PAPER_BIN = "icrt+bin (paper)"
OFFICIAL_ROWS = (
    (OFFICIAL_PAPER_LIPVQ, None),
    ("icrt+lipvq (official code)", OFFICIAL_PAPER_LIPVQ),
    ("last layer only", OFFICIAL_PAPER_LIPVQ),
    ("detached latent", OFFICIAL_PAPER_LIPVQ),
    ("no Lipschitz loss", OFFICIAL_PAPER_LIPVQ),
    (OFFICIAL_PAPER_BIN, None),
    ("icrt+bin (official code)", OFFICIAL_PAPER_BIN),
    ("prompts from the minibatch", OFFICIAL_PAPER_LIPVQ),
)
"""The `official` table's rows: (label, the paper's row it is compared with, or None)."""


OFFICIAL_SINGLE_DIFFERENCES = {
    "last layer only": ("norm", "output_activation", "lipschitz.per_row", "lipschitz.c_init",
                        "lipschitz.weight_init"),
    "detached latent": ("detach_embeddings",),
    "no Lipschitz loss": ("lipschitz.weight",),
}
"""Row -> the fields it takes from `lipvq_official()` (every other field the paper's)."""


def _leaf_values(config, prefix: str = "") -> dict[str, object]:
    out = {}
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if dataclasses.is_dataclass(value):
            out.update(_leaf_values(value, f"{prefix}{f.name}."))
        else:
            out[f"{prefix}{f.name}"] = value
    return out


def config_differences(a, b) -> dict[str, tuple[object, object]]:
    """{dotted field path: (value in `a`, value in `b`)} where two configs differ."""
    va, vb = _leaf_values(a), _leaf_values(b)
    return {path: (va[path], vb[path]) for path in va if va[path] != vb[path]}


def _take_fields(base, source, paths: Sequence[str]):
    """`base` with the fields at `paths` set to `source`'s values."""
    for path in paths:
        base = replace_path(base, path, get_path(source, path))
    return base


def official_configs(preset: Preset) -> dict[str, tuple]:
    """Row -> (ICRT config, tokenizer config): the official-code rows take every field where
    `lipvq_official()` / `official_bin()` differ from the paper's onto the preset's config."""
    icrt, lipvq, bin_ = preset.policies.icrt, preset.tokenizers.lipvq, preset.tokenizers.bin
    off_lipvq = lipvq_official(lipvq.latent_dim, lipvq.codebook_size)
    off_bin = official_bin(bin_.latent_dim)
    all_lipvq = config_differences(off_lipvq, LipVQConfig(latent_dim=lipvq.latent_dim,
                                                          codebook_size=lipvq.codebook_size))
    all_bin = config_differences(off_bin, BinConfig(latent_dim=bin_.latent_dim))
    out = {OFFICIAL_PAPER_LIPVQ: (icrt, lipvq),
           "icrt+lipvq (official code)": (icrt, _take_fields(lipvq, off_lipvq, all_lipvq))}
    for name, paths in OFFICIAL_SINGLE_DIFFERENCES.items():
        out[name] = (icrt, _take_fields(lipvq, off_lipvq, paths))
    out[OFFICIAL_PAPER_BIN] = (icrt, bin_)
    out["icrt+bin (official code)"] = (icrt, _take_fields(bin_, off_bin, all_bin))
    out["prompts from the minibatch"] = (dataclasses.replace(icrt, prompt_from="minibatch"),
                                         lipvq)
    return out


def official_seeds(preset: Preset) -> int:
    """Training seeds of every `official` row: `tables.official_seeds`, else `icrt_seeds`."""
    return preset.tables.official_seeds or preset.tables.icrt_seeds


def spec(preset: Preset) -> TableSpec:
    """The `official` table: each of `OFFICIAL_ROWS` on Table I's protocol, success per
    family and on average, and features."""
    tasks = preset.data.robocasa_tasks
    configs = official_configs(preset)
    paper_rows = {OFFICIAL_PAPER_LIPVQ: label("icrt", "lipvq"),
                  OFFICIAL_PAPER_BIN: label("icrt", "bin")}
    rows = []
    for name, _ in OFFICIAL_ROWS:
        policy, tok = configs[name]
        seeds = row_seeds(preset, "official", name, official_seeds(preset))
        if name in paper_rows:  # Table I's runs
            seeds = max(seeds, table_i_seeds(preset, "icrt", paper_rows[name].split("+")[1]))
        runs = [r.replace(policy=policy) for r in seed_runs(preset, "icrt", tok, tasks, seeds)]
        entries = family_entries(preset, runs, tasks)
        entries["features"] = features_entry(preset, runs)
        rows.append(Row(name, entries, TABLE_I_ROBOCASA[paper_rows[name]]
                        if name in paper_rows else {}))
    return TableSpec("official", "The paper against its official code (Meta-World, "
                                 "Table I's protocol)",
                     (*FAMILY_COLUMNS, "avg", "features"), tuple(rows), note=(
                         "ICRT with the paper's LipVQ-VAE and Bin (Table I's policies) beside "
                         "the official code's LipVQ-VAE (every difference, and three alone), "
                         "Bin and prompts; `features`: codes used, latent scale, least energy."))


# --------------------------------------------------------------------------- the findings
DIRECTION = +1
"""The verdict reads "the variant succeeds more than its base"."""


def comparisons() -> list[tuple[str, str]]:
    """(variant, base) of every comparison, in the table's row order."""
    return [(row, base) for row, base in OFFICIAL_ROWS if base is not None]


def codes_used(result: TableResult, row: str) -> list[int] | None:
    """Codes each seed's tokenizer uses on the held-out trajectories (None while not run)."""
    entry = result.features(row)
    if entry is None:
        return None
    values = [m.get("codes_used") for m in entry.extra["metrics"]]
    return None if any(v is None for v in values) else [int(v) for v in values]


def codebook_size(result: TableResult, row: str) -> int | None:
    """The row's number of distinct codes (for Bin: action dimensions x bins)."""
    entry = result.features(row)
    if entry is None:
        return None
    sizes = {m.get("codebook_size") for m in entry.extra["metrics"]}
    return sizes.pop() if len(sizes) == 1 else None


def findings(result: TableResult) -> list[dict[str, Any]]:
    """Per comparison: `variant`, `base`, `estimate` (paired success difference), `verdict`,
    `adjusted_verdict` (Holm over the table), `seeds`, `variant_codes`, `base_codes`."""
    out = []
    for variant, base in comparisons():
        xa, xb = result.outcomes(variant, "avg"), result.outcomes(base, "avg")
        est = (None if xa is None or xb is None else
               stats.paired_difference(xa, xb, scenes=result.scenes(variant, base)))
        out.append({"variant": variant, "base": base, "estimate": est,
                    "verdict": Verdict.NOT_RUN if est is None else stats.verdict(est, DIRECTION),
                    "seeds": None if est is None else {variant: len(xa), base: len(xb)},
                    "variant_codes": codes_used(result, variant),
                    "base_codes": codes_used(result, base)})
    adjusted = stats.adjusted_verdicts([f["estimate"] for f in out], [DIRECTION] * len(out))
    for f, a in zip(out, adjusted, strict=True):
        f["adjusted_verdict"] = a
    return out


def _codes_text(codes: list[int] | None) -> str:
    if codes is None:
        return "-"
    return f"{np.mean(codes):.3g}" if len(set(codes)) == 1 else (
        f"{np.mean(codes):.3g} ({min(codes)}-{max(codes)})")


def findings_frame(result: TableResult):
    """`findings` as a table, verdicts in words, codes used as mean (range)."""
    import pandas as pd

    rows = []
    for f in findings(result):
        est = f["estimate"]
        seeds = "" if f["seeds"] is None else " v ".join(map(str, f["seeds"].values()))
        rows.append({"variant": f["variant"], "against": f["base"], "seeds": unbroken(seeds),
                     "success difference": (verdict_words.MISSING if est is None
                                            else unbroken(format_difference(est))),
                     "verdict": verdict_words.OUTCOME[f["verdict"]],
                     "after Holm": verdict_words.OUTCOME[f["adjusted_verdict"]],
                     "codes used": _codes_text(f["variant_codes"]),
                     "base's codes": _codes_text(f["base_codes"])})
    return pd.DataFrame(rows).set_index("variant").rename_axis(None)


def codes_frame(result: TableResult, digits: int = 2):
    """Per row: success, codes used, codebook size, sigma and standardized least energy."""
    import pandas as pd

    out = []
    for row in result.spec.rows:
        line: dict[str, Any] = {"": row.label, "success": unbroken(
            format_entry(result.entry(row.label, "avg"), digits))}
        feat = result.features(row.label)
        if feat is None:
            line["codes used"] = verdict_words.MISSING
        else:
            size = codebook_size(result, row.label)
            std = feat.extra["standardized_estimate"]
            line.update({"codes used": _codes_text(codes_used(result, row.label)),
                         "codebook": "-" if size is None else str(size),
                         "σ": f"{float(np.mean(feat.extra['latent_scale'])):.3g}",
                         "standardized least energy": f"{std.value:.3g}"})
        out.append(line)
    return pd.DataFrame(out).set_index("")


def differences_frame(result: TableResult):
    """One line per field a variant's run spec changes against its base's (seed 0)."""
    import pandas as pd

    runs = {row.label: row.entries["avg"].units[0].run for row in result.spec.rows}
    lines = []
    for variant, base in comparisons():
        a, b = runs[variant], runs[base]
        changes = {f"policy.{k}": v for k, v in config_differences(a.policy, b.policy).items()}
        if type(a.tokenizer) is type(b.tokenizer):
            changes.update({f"tokenizer.{k}": v for k, v in
                            config_differences(a.tokenizer, b.tokenizer).items()})
        for field, (va, vb) in changes.items():
            lines.append({"variant": variant, "field": field, "variant's": repr(va),
                          "paper's": repr(vb)})
    return pd.DataFrame(lines).set_index(["variant", "field"]).rename_axis([None, None])


def collapsed_rows(result: TableResult) -> list[str]:
    """Rows whose tokenizer uses a single code on the held-out trajectories at every seed."""
    return [row.label for row in result.spec.rows
            if (codes := codes_used(result, row.label)) is not None and max(codes) <= 1]
