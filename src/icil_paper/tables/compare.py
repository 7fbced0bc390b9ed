"""`icil-paper compare`: a tokenizer against the paper's, on Table I's protocol, with a verdict.

    icil-paper compare --plugin ./my_tok.py --tokenizer mine --against lipvq --preset small
    report = compare(preset, "mine", against=("lipvq",), effect=0.05)   # from code

Rows `icrt+<tokenizer>` and `icrt+<other>` use Table I's runs and evaluations, so stored
records are reused. With `--seeds N` every row gets N seeds; otherwise `pilot_seeds` first,
then as many as detect `--effect` with 80% power (at most `--max-seeds`). Each comparison is
a claim of our own read by the claims ledger (`claims.evaluate_claims`, Holm over the
comparisons). Output: the lines printed, `compare.json` and `compare.png` (a forest plot) in
`results/<preset>/compare/<tokenizer>/` unless `--out` names a folder.
"""

from __future__ import annotations

import dataclasses
import sys
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from icil_paper import plugins, stats
from icil_paper.commands import (
    Parser,
    add_executor_arguments,
    add_preset_arguments,
    check_executor_arguments,
    positive,
    preset_from_args,
)
from icil_paper.config import Preset
from icil_paper.data.generate import check_tasks
from icil_paper.fileio import atomic_write_json, check_env_folder, check_writable
from icil_paper.policies import resolve_tokenizer
from icil_paper.records import train_record
from icil_paper.registry import check_name
from icil_paper.results import RESULTS_ENV_VAR, ResultsStore
from icil_paper.tables import claims as claims_mod
from icil_paper.tables.assemble import TableResult, assemble
from icil_paper.tables.cells import check_reachable, run_specs
from icil_paper.tables.definitions import icrt_rows, label, table_i_seeds
from icil_paper.tables.display import forest_plot
from icil_paper.tokenizers.configs import TOKENIZER_REGISTRY as REGISTRY
from icil_paper.train.rundir import RUNS_ENV_VAR

DEFAULT_AGAINST = ("lipvq",)
DEFAULT_EFFECT = 0.05
"""A difference of 5 points of average success: the size of the gaps the paper reports."""
PILOT_SEEDS = 2
"""Seeds a row gets before its variance is measured (2: the fewest that measure one)."""
MAX_SEEDS = 10
"""The most seeds a row is planned up to by default (the reference design's)."""
SHARED_SIZES = ("latent_dim", "codebook_size")
"""The tokenizer fields every preset gives all its tokenizers alike (`config._tokenizers`)."""
REPORT_FILE = "compare.json"
PLOT_FILE = "compare.png"


def check_tokenizers(tokenizer: str, against: Sequence[str]) -> None:
    """Every name registered and taken by ICRT, and none compared with itself (ValueError)."""
    if not against:
        raise ValueError("--against needs at least one tokenizer (default: lipvq)")
    for name in (tokenizer, *against):
        check_name("tokenizer", name, list(REGISTRY))
        resolve_tokenizer("icrt", name)
    if tokenizer in against or len(set(against)) != len(against):
        raise ValueError(f"compare {tokenizer} against other tokenizers, each once; got "
                         f"--against {' '.join(against)}")


def with_registered(preset: Preset) -> Preset:
    """`preset` with a config for every tokenizer registered since it was built, given the
    `SHARED_SIZES` the preset gives all its tokenizers alike."""
    section = preset.tokenizers
    current = dict(section)
    new = {name: cls for name, cls in section.REGISTRY.configs.items()
           if name.replace("-", "_") not in current}
    if not new:
        return preset
    for name, cls in new.items():
        shared = {}
        for f in dataclasses.fields(cls):
            values = {repr(getattr(c, f.name)): getattr(c, f.name) for c in current.values()
                      if hasattr(c, f.name)}
            if f.name in SHARED_SIZES and len(values) == 1:
                shared[f.name] = next(iter(values.values()))
        current[name.replace("-", "_")] = cls(**shared)
    return dataclasses.replace(preset, tokenizers=type(section)(**current))


def _claims(tokenizer: str, against: Sequence[str], effect: float) -> list[claims_mod.Claim]:
    a = label("icrt", tokenizer)
    return [claims_mod.Claim(
        id=f"compare-{tokenizer}-vs-{other}", table="I",
        claim=f"{a} succeeds more often than {label('icrt', other)} on Table I's protocol",
        quantity=f"{a} minus {label('icrt', other)}, average success over the kitchen tasks",
        direction=+1, compare=claims_mod.diff("I", a, label("icrt", other)),
        paper_value=lambda: effect, own=True,
        reference=f"the effect of interest (--effect {effect:g})") for other in against]


def plan_seeds(result: TableResult, tokenizer: str, against: Sequence[str], effect: float,
               max_seeds: int) -> dict[str, Any]:
    """The seeds a row that detect `effect` against every other row (at Holm's first level,
    `stats.seeds_needed`), capped at `max_seeds`."""
    a = label("icrt", tokenizer)
    needed = []
    for other in against:
        rows = (result.outcomes(a), result.outcomes(label("icrt", other)))
        paired = result.scenes(a, label("icrt", other)) == "per_seed"
        var = (stats.seed_variance(rows[0], other=rows[1])
               if paired else None if min(len(r) for r in rows) < 2
               else stats.seed_variance(rows[0]) + stats.seed_variance(rows[1]))
        if var is None:
            return {"needed": None, "planned": None,
                    "note": "a row has fewer than 2 seeds: no variance to plan from"}
        needed.append(stats.seeds_needed(var, effect, alpha=stats.ALPHA / len(against),
                                         paired=paired, max_seeds=claims_mod.MAX_SEEDS))
    worst = None if any(n is None for n in needed) else max(needed)
    planned = max_seeds if worst is None else min(worst, max_seeds)
    if worst is None:
        note = (f"detecting {effect:g} would need more than {claims_mod.MAX_SEEDS} seeds a "
                f"row; capped at --max-seeds {max_seeds}")
    elif worst > max_seeds:
        note = f"{worst} seeds a row would detect {effect:g}; capped at --max-seeds {max_seeds}"
    else:
        note = f"{worst} seeds a row detect {effect:g} with 80% power"
    return {"needed": worst, "planned": planned, "note": note}


def other_versions(spec, store: ResultsStore) -> dict[str, int]:
    """Row -> its stored training records made by another version of its plugin."""
    current = {(name, p.sha256, p.version) for p in plugins.loaded()
               for names in p.names.values() for name in names}
    out: Counter[str] = Counter()
    runs = {u.run.key(): (row.label, u.run) for row in spec.rows
            for entry in row.entries.values() for u in entry.units}
    for label_, run in runs.values():
        for made in (store.get(*train_record(run)) or {}).get("plugins") or []:
            out[label_] += sum((name, made.get("sha256"), made.get("version")) not in current
                               for name in made["names"].get("tokenizer", []))
    return {row: n for row, n in out.items() if n}


def compare(preset: Preset, tokenizer: str, against: Sequence[str] = DEFAULT_AGAINST,
            effect: float = DEFAULT_EFFECT, seeds: int | None = None,
            pilot_seeds: int = PILOT_SEEDS, max_seeds: int = MAX_SEEDS,
            executor: str = "local", workers: int | None = None,
            ray_address: str | None = None, gpus_per_cell: float = 0.0,
            progress: bool = True) -> dict[str, Any]:
    """Run (or load) the comparison and return its report (module docstring)."""
    against = tuple(against)
    preset = with_registered(preset)
    check_tokenizers(tokenizer, against)
    if not effect > 0:
        raise ValueError(f"--effect must be a difference of success above 0, got {effect}")
    names = (tokenizer, *against)
    stored = {t: table_i_seeds(preset, "icrt", t) for t in names}
    first = seeds or pilot_seeds
    counts = {t: max(first, stored[t] if seeds is None else 0) for t in names}
    run = dict(executor=executor, workers=workers, ray_address=ray_address,
               gpus_per_cell=gpus_per_cell, progress=progress)
    run_specs(preset, [icrt_rows(preset, counts)], **run)
    store = ResultsStore(preset.name)
    result = assemble(icrt_rows(preset, counts), store)
    seed_plan: dict[str, Any] = {"fixed": seeds, "pilot": None if seeds else first,
                                 "max_seeds": max_seeds, "effect": effect}
    if seeds is None:
        seed_plan.update(plan_seeds(result, tokenizer, against, effect, max_seeds))
        if seed_plan["planned"] and seed_plan["planned"] > min(counts.values()):
            counts = {t: max(n, seed_plan["planned"]) for t, n in counts.items()}
            run_specs(preset, [icrt_rows(preset, counts)], **run)
            result = assemble(icrt_rows(preset, counts), store)
    seed_plan["seeds"] = counts
    stale = other_versions(icrt_rows(preset, counts), store)
    entries = claims_mod.evaluate_claims(_claims(tokenizer, against, effect), {"I": result})
    rows = {}
    for name in names:
        est = result.estimate(label("icrt", name))
        rows[label("icrt", name)] = None if est is None else {
            "success": est.value, "ci": [est.low, est.high], "seeds": counts[name]}
    used = [p.record() for p in plugins.loaded()
            if any(n in names for n in p.names.get("tokenizer", ()))]
    return {"preset": preset.name, "tokenizer": tokenizer, "against": list(against),
            "protocol": "Table I: ICRT on every kitchen task, average success",
            "familywise_level": stats.ALPHA, "effect": effect, "rows": rows,
            "seed_plan": seed_plan, "comparisons": entries, "plugins": used,
            "other_versions": stale, "records": str(store.dir)}


OWN_WORDS = {"the paper's size": "the size of the effect of interest",
             "the paper's effect": "the effect of interest"}
"""The ledger's words for the paper's number, as a comparison against `--effect` reads them."""


def sentence(entry: dict[str, Any]) -> str:
    """A comparison in the claims ledger's words, sized against the effect of interest."""
    text = claims_mod.sentence(entry)
    for ledger, own in OWN_WORDS.items():
        text = text.replace(ledger, own)
    return text


def lines(report: dict[str, Any]) -> list[str]:
    """The report in words: the rows, each comparison in the ledger's words, the plan."""
    out = [f"{report['tokenizer']} against {', '.join(report['against'])} on Table I's "
           f"protocol ({report['preset']} preset):"]
    for row, value in report["rows"].items():
        out.append(f"  {row}: " + (stats.Verdict.NOT_RUN.value if value is None else
                                   f"average success {value['success']:.3f} "
                                   f"[{value['ci'][0]:.3f}, {value['ci'][1]:.3f}], "
                                   f"{value['seeds']} seeds"))
    for entry in report["comparisons"]:
        out.append(f"  {sentence(entry)}")
        if entry.get("power") is not None:
            out.append(f"    power at {report['effect']:g}: {entry['power']:.2f}; smallest "
                       f"detectable difference {entry['mde']:.3f}")
        elif entry.get("power_note"):
            out.append(f"    power: {entry['power_note']}")
    plan_ = report["seed_plan"]
    out.append("  seeds: " + (f"fixed at {plan_['fixed']} a row" if plan_["fixed"] else
                              f"pilot {plan_['pilot']} a row, then {plan_.get('note')}"))
    for p in report["plugins"]:
        out.append(f"  plugin: {plugins.needed_by([p])}")
    for row, n in (report.get("other_versions") or {}).items():
        out.append(f"  warning: {n} stored {row} cell(s) were made by another version of its "
                   f"plugin and are reused; delete their records under {report['records']} "
                   "to recompute them")
    return out


def write(report: dict[str, Any], folder: str | Path) -> tuple[Path, Path]:
    """`compare.json` and `compare.png` (the comparisons' `display.forest_plot`) in `folder`."""
    import matplotlib

    matplotlib.use("Agg")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    atomic_write_json(folder / REPORT_FILE, report)
    fig = forest_plot(report["comparisons"], label=lambda e: e.quantity.split(",")[0],
                      title=f"{report['tokenizer']} on Table I's protocol ({report['preset']})")
    fig.savefig(folder / PLOT_FILE, dpi=120)
    return folder / REPORT_FILE, folder / PLOT_FILE


def main(argv: list[str] | None = None) -> int:
    parser = Parser(prog="icil-paper compare", description=__doc__.split("\n\n")[0])
    add_preset_arguments(parser)
    parser.add_argument("--tokenizer", required=True,
                        help="the tokenizer to compare (a built-in or a --plugin's)")
    parser.add_argument("--against", nargs="+", default=list(DEFAULT_AGAINST),
                        help="the tokenizers it is compared with (default: lipvq)")
    parser.add_argument("--effect", type=float, default=DEFAULT_EFFECT,
                        help="the difference of average success to detect (default 0.05)")
    parser.add_argument("--seeds", type=positive("--seeds"), default=None,
                        help="training seeds a row (default: planned from the variances)")
    parser.add_argument("--pilot-seeds", type=positive("--pilot-seeds"), default=PILOT_SEEDS,
                        help=f"seeds a row before planning (default {PILOT_SEEDS})")
    parser.add_argument("--max-seeds", type=positive("--max-seeds"), default=MAX_SEEDS,
                        help=f"the most seeds a row is planned up to (default {MAX_SEEDS})")
    add_executor_arguments(parser)
    parser.add_argument("--out", default=None, metavar="DIR",
                        help="folder of compare.json and compare.png (default: "
                             "results/<preset>/compare/<tokenizer>)")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    args = parser.parse_args(argv)
    check_executor_arguments(parser, args)
    if not 0 < args.effect < 1:
        parser.error(f"--effect must be a difference of success between 0 and 1, got "
                     f"{args.effect}")
    if args.pilot_seeds < 2 and args.seeds is None:
        parser.error("--pilot-seeds must be at least 2 (one seed measures no variance)")
    preset = preset_from_args(args)
    check_tasks(preset)
    check_tokenizers(args.tokenizer, args.against)
    check_env_folder(RESULTS_ENV_VAR, "results")
    check_env_folder(RUNS_ENV_VAR, "runs")
    out = Path(args.out or ResultsStore(preset.name).dir / "compare" / args.tokenizer)
    check_writable(out, f"the report folder {out}", "pass another --out")
    if args.executor == "ray" and args.ray_address:
        check_reachable(args.ray_address)
    report = compare(preset, args.tokenizer, args.against, effect=args.effect,
                     seeds=args.seeds, pilot_seeds=args.pilot_seeds, max_seeds=args.max_seeds,
                     executor=args.executor, workers=args.workers,
                     ray_address=args.ray_address, gpus_per_cell=args.gpus_per_cell,
                     progress=not args.quiet)
    json_path, png_path = write(report, out)
    print("\n".join(lines(report)))
    print(f"report {json_path}; forest plot {png_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
