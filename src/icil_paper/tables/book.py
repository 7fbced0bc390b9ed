"""What the table chapters show: the paper, the reference run and this build, side by side.

    results = load_table(preset, "I")               # {"this build": ..., "reference": ...}
    compare_frame(results, "avg")                   # rows x (paper, reference, this build)
    success_figure(results, "avg")                  # bars with 95% intervals, the paper's marks
    show_motion(results, "avg")                     # success beside LDLJ, SPARC, action jerk
    verdicts(preset, "I")                           # the ledger's sentences, in Markdown

`load_table` computes what this build's results store lacks (through the same function
`icil-paper reproduce` calls, so after `make reproduce` it only loads) and reads the
reference run's committed records (`results/reference/`) without computing anything: a
reference cell that is not there yet shows as "not run", and a committed record whose key
the current code no longer computes is listed as stale (`stale_records`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from icil_paper import verdict_words
from icil_paper.config import Preset, get_preset
from icil_paper.results import ResultsStore
from icil_paper.stats import Verdict
from icil_paper.tables.assemble import TableResult, assemble, format_cell, unbroken
from icil_paper.tables.claims import CLAIM_LABELS, LedgerEntry, as_entry, sizing_effect
from icil_paper.tables.definitions import table_spec

REFERENCE = "reference"
BUILD = "this build"


def load_table(preset: Preset, table_id: str, compute: bool = True,
               progress: bool = True) -> dict[str, TableResult]:
    """{"reference run": ..., "this build": ...} for one table (one entry when the build is
    the reference preset itself)."""
    from icil_paper.tables.execute import run_tables

    if compute:
        run_tables(preset, [table_id], progress=progress)
    results = {}
    if preset.name != REFERENCE:
        ref = get_preset(REFERENCE)
        results[f"{REFERENCE} run"] = assemble(table_spec(ref, table_id), ResultsStore(REFERENCE))
    results[BUILD] = assemble(table_spec(preset, table_id), ResultsStore(preset.name))
    return results


def source_label(source: str, preset_name: str) -> str:
    """"this build (small)"; "reference run" (its preset is in its name already)."""
    return source if preset_name in source else f"{source} ({preset_name})"


def compare_frame(results: dict[str, TableResult], column: str = "avg", digits: int = 3):
    """Rows x (paper, reference, this build) for one column, as `value [low, high]`."""
    import pandas as pd

    any_result = next(iter(results.values()))
    out = []
    for row in any_result.spec.rows:
        line: dict[str, Any] = {"": row.label}
        value = row.paper.get(column)
        line["paper"] = "" if value is None else f"{value:.{digits}f}"
        for source, result in results.items():
            line[source_label(source, result.preset)] = format_cell(result.cell(row.label, column),
                                                              digits)
        out.append(line)
    return pd.DataFrame(out).set_index("")


def success_figure(results: dict[str, TableResult], column: str = "avg", title: str = "",
                   ylabel: str = "success rate"):
    """Grouped bars per row: each source's estimate with its 95% interval; the paper's
    number as a black mark. With a reference run beside it, this build is left out (its
    numbers test the code; they are in the collapsed block under the table)."""
    import matplotlib.pyplot as plt

    if len(results) > 1:
        results = {k: v for k, v in results.items() if k != BUILD}

    spec = next(iter(results.values())).spec
    labels = [r.label for r in spec.rows]
    fig, ax = plt.subplots(figsize=(max(6.0, 0.9 * len(labels) + 2), 3.6))
    width = 0.8 / max(1, len(results))
    x = np.arange(len(labels))
    for k, (source, result) in enumerate(results.items()):
        vals, lo, hi = [], [], []
        for label in labels:
            est = result.estimate(label, column)
            vals.append(est.value if est else np.nan)
            lo.append(est.value - est.low if est else 0.0)
            hi.append(est.high - est.value if est else 0.0)
        ax.bar(x + (k - (len(results) - 1) / 2) * width, vals, width, yerr=[lo, hi], capsize=3,
               label=source_label(source, result.preset), alpha=0.85)
    paper = [next(r for r in spec.rows if r.label == label).paper.get(column) for label in labels]
    if any(p is not None for p in paper):
        ax.scatter(x, [np.nan if p is None else p for p in paper], marker="_", s=400,
                   color="black", zorder=5, label="the paper")
    ax.set_xticks(x, labels, rotation=30, ha="right")
    ax.set_ylabel(ylabel)
    ax.set_title(title or f"Table {spec.id}, {column}")
    ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    plt.close(fig)  # shown once, by the caller's display(fig)
    return fig


MOTION_COLUMNS = {"ldlj": "LDLJ (higher: smoother)", "sparc": "SPARC (higher: smoother)",
                  "action_jerk": "action jerk (lower: smoother)"}
"""The motion frame's columns beside success (`icil_paper.metrics`)."""


def _format_estimate(est, digits: int = 3) -> str:
    """`-12.3 [-13.1, -11.6]` (`digits` significant digits, trailing zeros kept) or
    `not run`."""
    if est is None:
        return verdict_words.MISSING

    def sig(x: float) -> str:
        return f"{x:#.{digits}g}".rstrip(".").replace(".e", "e")

    return unbroken(f"{sig(est.value)} [{sig(est.low)}, {sig(est.high)}]")


def motion_frame(result: TableResult, column: str = "avg", digits: int = 3):
    """Rows x (success, LDLJ, SPARC, action jerk) of one column: each row's success and the
    smoothness of its rollouts' motion (per-seed means of per-episode values, the seed as
    the unit: `TableResult.motion_estimate`), each `value [95% interval]`."""
    import pandas as pd

    out = []
    for row in result.spec.rows:
        cell = result.cell(row.label, column)
        line: dict[str, Any] = {"": row.label, "success": unbroken(format_cell(cell, 2))}
        for measure, name in MOTION_COLUMNS.items():
            line[name] = ("n/a" if cell is None else
                          _format_estimate(result.motion_estimate(row.label, column, measure),
                                           digits))
        out.append(line)
    return pd.DataFrame(out).set_index("")


def motion_note(result: TableResult, column: str = "avg") -> str:
    """How many of the column's episodes have each measure defined (an episode of a few
    steps, or one where the arm did not move, has none), as a clause; empty when all do."""
    counts = {}
    for row in result.spec.rows:
        cell = result.cell(row.label, column)
        for measure in MOTION_COLUMNS:
            if cell is not None and measure in cell.motion:
                values = cell.motion[measure]
                done, total = counts.get(measure, (0, 0))
                counts[measure] = (done + int(np.isfinite(values).sum()), total + values.size)
    gaps = [f"{MOTION_COLUMNS[m].split(' (')[0]} {d} of {t}" for m, (d, t) in counts.items()
            if d < t]
    return "" if not gaps else "episodes with the measure defined: " + ", ".join(gaps)


def show_motion(results: dict[str, TableResult], column: str = "avg", digits: int = 3) -> None:
    """Success beside the smoothness of the motion that earned it (`motion_frame`), for the
    reference run, then this build in a collapsed block (`show_per_source`)."""
    def describe(result: TableResult) -> str:
        note = motion_note(result, column)
        return (f"{column}, each episode's value averaged per seed, 95% intervals with the "
                "seed as the unit" + (f"; {note}" if note else ""))

    show_per_source(results, lambda r: motion_frame(r, column, digits), describe)


def verdicts(preset: Preset, table_id: str) -> str:
    """The claims ledger's sentences about one table, for the reference run and this build,
    as Markdown (generated from the numbers, never written by hand)."""
    from icil_paper.tables.claims import claims_ledger, sentence

    sources = [(BUILD, preset)]
    if preset.name != REFERENCE:
        sources.insert(0, (f"{REFERENCE} run", get_preset(REFERENCE)))
    lines = []
    for source, p in sources:
        entries = [e for e in claims_ledger(p, ResultsStore(p.name)) if e.table == table_id]
        if not entries:
            continue
        lines.append(f"**{source_label(source, p.name)}**\n")
        lines += [f"- *{e.claim}* {sentence(e)}" for e in entries]
        lines.append("")
    return "\n".join(lines)


def stale_records(preset_name: str = REFERENCE) -> list[str]:
    """Records in `results/<preset>/` (train, eval, features) whose key neither a current
    cell of any table nor chapter 02's run computes: results of an older version of the
    code or presets."""
    from icil_paper.book.studies import icrt_specs
    from icil_paper.runspec import eval_key, feature_key
    from icil_paper.tables.definitions import TABLES
    from icil_paper.tables.execute import plan

    preset = get_preset(preset_name)
    keys = set()
    for p in plan([table_spec(preset, t) for t in TABLES]):
        keys.add(p.run.key())
        keys.update(eval_key(p.run, ev) for ev in p.evals.values())
        keys.update(feature_key(p.run, f) for f in p.features.values())
    run, ev = icrt_specs(preset)
    keys.update((run.key(), eval_key(run, ev)))
    store = ResultsStore(preset_name)
    return sorted(f"{r['kind']}/{r['name']}" for kind in ("train", "eval", "features")
                  for r in store.records(kind) if r["config_hash"] not in keys)


def _collapsed(summary: str, frame) -> Any:
    """A frame inside a closed <details> block (the reader opens it)."""
    from IPython.display import HTML

    return HTML(f"<details class='icil-build'><summary>{summary}</summary>"
                f"{frame.to_html(classes='dataframe')}</details>")


def _markdown_html(text: str) -> str:
    """The little Markdown the ledger's lists use (items, **bold**, *italic*, `code`) as
    HTML, for a collapsed block (HTML output is not read as Markdown)."""
    import html
    import re

    def inline(line: str) -> str:
        line = html.escape(line, quote=False)
        line = re.sub(r"\*\*(.+?)\*\*", r"<b>\1</b>", line)
        line = re.sub(r"\*(.+?)\*", r"<i>\1</i>", line)
        return re.sub(r"`(.+?)`", r"<code>\1</code>", line)

    items = [line[2:] for line in text.splitlines() if line.startswith("- ")]
    if not items:
        return f"<p>{inline(text)}</p>"
    return "<ul>" + "".join(f"<li>{inline(i)}</li>" for i in items) + "</ul>"


def collapsed_markdown(summary: str, text: str) -> Any:
    """A Markdown list (or paragraph) inside a closed <details> block."""
    from IPython.display import HTML

    return HTML(f"<details class='icil-build'><summary>{summary}</summary>"
                f"{_markdown_html(text)}</details>")


def show_ledger(ledger: list[LedgerEntry | dict[str, Any]], heading: str,
                progress: str = "") -> None:
    """Chapter 0's view of one ledger: the forest plot first (each row labelled by what its
    claim says), the counts in one sentence and the verdicts; then, collapsed, the power of
    each undecided claim and the size-and-power table; the run's bookkeeping (`progress`)
    last."""
    from IPython.display import Markdown, display

    from icil_paper.tables.claims import summary_sentence

    ledger = [as_entry(e) for e in ledger]
    display(Markdown(f"## {heading[0].upper()}{heading[1:]}"))
    display(forest_plot(ledger, title=f"{heading[0].upper()}{heading[1:]}: each claim's 95% "
                                      "interval, the paper's value, the verdict after Holm"))
    display(Markdown(summary_sentence(ledger)))
    display(Markdown("**Verdicts** (the seeds of each row: the claim's row first)"))
    display(ledger_frame(ledger, "verdicts"))
    undecided = undecided_power(ledger)
    if undecided:
        n = len(undecided.splitlines())
        display(collapsed_markdown(f"Undecided after Holm ({n} claims): what these seeds "
                                   "could detect. Open to see them.", undecided))
    display(_collapsed("Size and power of every claim. Open to see them.",
                       ledger_frame(ledger, "power")))
    if progress:
        display(Markdown(progress))


def show_ledgers(ledgers: dict[str, tuple[Any, list]]) -> None:
    """Chapter 0's opening: `show_ledger` for each source ({source: (preset, ledger)}); while
    no claim of the reference ledger has run under the current protocol, the older
    protocol's ledger (`older_ledger`) follows it, headed with its commit, so the chapter
    opens on numbers."""
    for source, (preset, ledger) in ledgers.items():
        reference = preset.name == REFERENCE
        show_ledger(ledger, source_label(source, preset.name),
                    reference_bookkeeping() if reference else "")
        older = (older_ledger(REFERENCE)
                 if reference and not any(as_entry(e).run for e in ledger) else None)
        if older is not None:
            made_by, claims = older
            show_ledger(claims, f"older protocol (commit {made_by['commit'][:7]})",
                        "The older protocol's baselines did not read the task's instruction "
                        "and its training seeds shared one demonstration set: read this "
                        "ledger as a record of that protocol, not of the paper's regime.")


def _build_summary(result: TableResult) -> str:
    return (f"This build's numbers ({result.preset} preset): they test the code, not the "
            "paper. Open to see them.")


def show_comparison(results: dict[str, TableResult], column: str = "avg",
                    digits: int = 3) -> None:
    """The paper and the reference run side by side; this build's numbers below, in a
    collapsed block (shown open when the book is built with the reference preset itself)."""
    from IPython.display import display

    frame = compare_frame(results, column, digits)
    build = results.get(BUILD)
    if build is None or len(results) == 1:
        display(frame)
        return
    build_column = source_label(BUILD, build.preset)
    display(frame.drop(columns=[build_column]))
    display(_collapsed(_build_summary(build), frame[["paper", build_column]]))


PROMPT_BASELINES = ("bc_transformer", "act")
"""Table I's rows that read the instruction and no prompt, shown beside the prompt ablation."""


def prompt_beside_baselines(table1: dict[str, TableResult], prompt: dict[str, TableResult],
                            digits: int = 3):
    """The prompt ablation's rows (ICRT + LipVQ-VAE with its task's prompt, another task's,
    the first steps of its own) beside Table I's baselines, which read the task's language
    instruction and no prompt: what a prompt adds over the instruction alone. One column
    per source (reference run, this build), average success with its 95% interval."""
    import pandas as pd

    out = []
    any_prompt = next(iter(prompt.values()))
    for row in any_prompt.spec.rows:
        line: dict[str, Any] = {"": f"ICRT + LipVQ-VAE, {row.label}",
                                "reads": "instruction and prompt"}
        for source, result in prompt.items():
            line[source_label(source, result.preset)] = format_cell(
                result.cell(row.label, "avg"), digits)
        out.append(line)
    for label in PROMPT_BASELINES:
        line = {"": label, "reads": "instruction only"}
        for source, result in table1.items():
            line[source_label(source, result.preset)] = format_cell(
                result.cell(label, "avg"), digits)
        out.append(line)
    return pd.DataFrame(out).set_index("")


def seed_correlations(result: TableResult, column: str = "avg") -> dict[tuple[str, str], float]:
    """{(row a, row b): Pearson r of their per-seed success at the same seed index}, over
    the seed indices both rows have (at least 3, and neither row constant over them).

    Seed k of every row shares its demonstration set, its evaluation scenes and, for the
    ICRT rows, its backbone's initial weights and batch order (common random numbers): the
    larger r, the more a paired comparison by seed index gains over an unpaired one."""
    per_seed = {}
    for row in result.spec.rows:
        cell = result.cell(row.label, column)
        if cell is not None and cell.data is not None and np.ndim(cell.data) >= 2:
            data = np.asarray(cell.data, dtype=np.float64)
            per_seed[row.label] = data.reshape(len(data), -1).mean(axis=1)
    out = {}
    labels = list(per_seed)
    for i, a in enumerate(labels):
        for b in labels[i + 1:]:
            n = min(len(per_seed[a]), len(per_seed[b]))
            x, y = per_seed[a][:n], per_seed[b][:n]
            if n >= 3 and x.std() > 0 and y.std() > 0:
                out[a, b] = float(np.corrcoef(x, y)[0, 1])
    return out


def seed_correlation_sentence(results: dict[str, TableResult], column: str = "avg") -> str:
    """The mean cross-row correlation of per-seed success in each source (`seed_correlations`),
    over every pair of rows and over the pairs of ICRT rows."""
    parts = []
    for source, result in results.items():
        r = seed_correlations(result, column)
        if not r:
            parts.append(f"{source_label(source, result.preset)}: no two rows have results "
                         "at 3 seed indices or more (nothing to correlate)")
            continue
        icrt = [v for (a, b), v in r.items() if a.startswith("icrt") and b.startswith("icrt")]
        text = (f"{source_label(source, result.preset)}: mean r = {np.mean(list(r.values())):.2f} "
                f"over {len(r)} pairs of rows")
        if icrt:
            text += f", {np.mean(icrt):.2f} over the {len(icrt)} pairs of ICRT rows"
        parts.append(text)
    return ("Correlation of per-seed success between two rows at the same seed index: "
            + "; ".join(parts) + ".")


def uninformative_columns(result: TableResult, prefix: str = "") -> dict[str, float]:
    """Columns (families or tasks; not "avg") where every row (whose label starts with
    `prefix`, e.g. "icrt+" for the tokenizers) is at 0, or every one at 1: they cannot
    separate those rows. Column -> the value every row has."""
    rows = [r for r in result.spec.rows if r.label.startswith(prefix)]
    out = {}
    for column in result.spec.columns:
        if column in ("avg", "features", "least_energy"):
            continue
        cells = [result.cell(r.label, column) for r in rows]
        cells = [c for c in cells if c is not None]
        values = [c.estimate.value for c in cells if c.estimate is not None]
        if len(values) >= 2 and len(values) == len(cells) and (
                all(v == 0.0 for v in values) or all(v == 1.0 for v in values)):
            out[column] = values[0]
    return out


def uninformative_note(results: dict[str, TableResult]) -> str:
    """A sentence per source naming its columns where every row is at 0 or at 1, and the
    share of the average they make (they add the same to every row, so differences in the
    average are diluted by that share). Empty when there are none."""
    lines = []
    for source, result in results.items():
        flat = uninformative_columns(result)
        if not flat and not uninformative_columns(result, "icrt+"):
            continue
        spec_row = result.spec.rows[0]
        tasks = {c: len({u.eval.task for u in cell.units if u.eval is not None})
                 for c, cell in spec_row.cells.items() if c not in ("avg", "features")}
        total = sum(tasks.values())
        share = sum(tasks.get(c, 0) for c in flat) / total if total else 0.0
        named = ", ".join(f"{c} (every row {v:.0f})" for c, v in flat.items())
        lines.append(f"- {source_label(source, result.preset)}: {named} cannot separate the "
                     f"rows; they hold {share:.0%} of the tasks in the average, so every "
                     f"difference in the average is diluted to {1 - share:.0%} of its size "
                     "on the tasks that can separate them.")
        icrt = {c: v for c, v in uninformative_columns(result, "icrt+").items() if c not in flat}
        if icrt:
            named = ", ".join(f"{c} (every ICRT row {v:.0f})" for c, v in icrt.items())
            lines.append(f"- {source_label(source, result.preset)}: {named} cannot separate "
                         "the ICRT tokenizers from one another.")
    return "" if not lines else ("**Uninformative columns** (computed):\n\n" + "\n".join(lines))


def show_values(results: dict[str, TableResult], digits: int = 2) -> None:
    """Display the paper's point values, then the reference run's, then this build's in a
    collapsed block (a one-line note for a source that has not computed the table yet), and
    the columns where every row is at 0 or 1."""
    from IPython.display import Markdown, display

    first = next(iter(results.values()))
    display(Markdown("**The paper**"))
    display(values_frame(first, digits, paper=True))
    for source, result in results.items():
        title = f"**{source_label(source, result.preset)}**"
        if not any(c.estimate is not None for c in result.cells.values()):
            display(Markdown(f"{title}: not run yet."))
            continue
        if source == BUILD and len(results) > 1:
            display(_collapsed(_build_summary(result), values_frame(result, digits)))
            continue
        display(Markdown(title))
        display(values_frame(result, digits))
    note = uninformative_note(results)
    if note:
        display(Markdown(note))


def values_frame(result: TableResult, digits: int = 2, paper: bool = False):
    """Point values only (rows x columns), compact enough for the wide family tables; with
    `paper`, the paper's numbers instead of ours."""
    import pandas as pd

    out = []
    for row in result.spec.rows:
        line: dict[str, Any] = {"": row.label}
        for column in result.spec.columns:
            if paper:
                value = row.paper.get(column)
            else:
                cell = result.cell(row.label, column)
                if cell is None or cell.estimate is None:
                    line[column] = "n/a" if cell is None else verdict_words.MISSING
                    continue
                value = cell.estimate.value
            line[column] = "" if value is None else round(float(value), digits)
        out.append(line)
    return pd.DataFrame(out).set_index("")


def smoothness_success_figure(smooth: dict[str, TableResult], success: dict[str, TableResult],
                              standardized: bool = False):
    """Fig. 1: least energy (Table III) against average success (Table I) of the six ICRT
    tokenizers, with 95% intervals on both axes; the paper's points beside ours (the paper's
    on its own axis, since the scales differ)."""
    import matplotlib.pyplot as plt

    from icil_paper import paper_numbers as paper

    rows = [r.label for r in next(iter(smooth.values())).spec.rows]
    n = len(smooth) + 1
    fig, axes = plt.subplots(1, n, figsize=(4.2 * n, 3.6))
    for ax, (source, result) in zip(axes, smooth.items(), strict=False):
        for label in rows:
            cell = result.cell(label, "least_energy")
            s_est = (cell.extra.get("standardized_estimate") if cell and standardized
                     else cell.estimate if cell else None)
            y_est = success[source].estimate(label, "avg")
            if s_est is None or y_est is None:
                continue
            ax.errorbar(s_est.value, y_est.value,
                        xerr=[[s_est.value - s_est.low], [s_est.high - s_est.value]],
                        yerr=[[y_est.value - y_est.low], [y_est.high - y_est.value]],
                        fmt="o", capsize=3)
            ax.annotate(label.split("+")[1], (s_est.value, y_est.value), fontsize=8,
                        xytext=(4, 4), textcoords="offset points")
        ax.set_xlabel(("standardized " if standardized else "") + "least energy (lower: smoother)")
        ax.set_ylabel("average success")
        ax.set_title(source_label(source, result.preset))
    ax = axes[-1]
    for label in rows:
        x, y = paper.TABLE_III_SMOOTHNESS[label], paper.TABLE_I_ROBOCASA[label]["avg"]
        ax.scatter(x, y, color="black")
        ax.annotate(label.split("+")[1], (x, y), fontsize=8, xytext=(4, 4),
                    textcoords="offset points")
    ax.set_xlabel("least energy (the paper)")
    ax.set_ylabel("average success (the paper)")
    ax.set_title("the paper (Table III vs Table I)")
    fig.tight_layout()
    plt.close(fig)  # shown once, by the caller's display(fig)
    return fig


def tsne_paths(smooth: TableResult, seed: int = 0) -> dict[str, np.ndarray]:
    """Fig. 4: each tokenizer's latents of the first steps of one held-out trajectory,
    projected to 2-D by t-SNE (scikit-learn), {row label: (steps, 2)} (seed 0's policy)."""
    from sklearn.manifold import TSNE

    paths = {}
    for row in smooth.spec.rows:
        cell = smooth.cell(row.label, "least_energy")
        if cell is None or cell.estimate is None:
            continue
        z = np.asarray(cell.extra["view"][0], dtype=np.float64)  # (steps, D)
        z = z + 1e-9 * np.random.default_rng(seed).standard_normal(z.shape)  # ties in codes
        perplexity = max(1.0, min(5.0, (len(z) - 1) / 3))
        paths[row.label] = TSNE(n_components=2, perplexity=perplexity, init="pca",
                                random_state=seed).fit_transform(z)
    return paths


def _seeds_cell(seeds: dict[str, int] | None) -> str:
    """"3 v 1" for a difference, "3 v 3 3 3" for a best of k (the claim's row first)."""
    if not seeds:
        return ""
    counts = list(seeds.values())
    return f"{counts[0]} v {' '.join(map(str, counts[1:]))}" if len(counts) > 1 else str(counts[0])


def ledger_frame(ledger: list[LedgerEntry | dict[str, Any]], part: str = "verdicts"):
    """The claims ledger as a table, in two parts that each fit the book's column:
    "verdicts" (the seeds a row, the paper, ours [95% interval], the verdict before and
    after Holm's correction) and "power" (the size reading, mde, the power to detect the
    paper's effect, seeds needed)."""
    ledger = [as_entry(e) for e in ledger]
    import pandas as pd

    if part not in ("verdicts", "power"):
        raise ValueError(f"part must be 'verdicts' or 'power', got {part!r}")
    rows = []
    for e in ledger:
        if part == "verdicts":
            ours = ("" if e.ours is None else
                    unbroken(f"{e.ours:+.3f} [{e.ci[0]:+.3f}, {e.ci[1]:+.3f}]"))
            paper_cell = (f"{e.paper:+.3f}" if e.paper is not None
                          else "—" if e.reference_effect is None
                          else f"({e.reference_effect:+.3f})")
            rows.append({"claim": e.id, "seeds": unbroken(_seeds_cell(e.seeds)),
                         "paper": paper_cell, "ours": ours, "verdict": e.verdict,
                         "after Holm": (e.adjusted_verdict or "")})
        else:
            needed = e.seeds_needed
            rows.append({"claim": e.id, "size vs the paper": e.magnitude or "",
                         "mde": "" if e.mde is None else f"{e.mde:.3f}",
                         "power": "" if e.power is None else f"{e.power:.0%}",
                         "seeds needed": ("" if e.verdict == Verdict.NOT_RUN else
                                          str(needed) if needed else "—")})
    return pd.DataFrame(rows).set_index("claim").rename_axis(None)


def undecided_power(ledger: list[LedgerEntry | dict[str, Any]]) -> str:
    """A Markdown list of the claims left undecided after Holm's correction, each with what
    its design could detect: the power to detect the paper's effect at its seeds, the mde
    and the seeds a row that would reach 80% power. Empty when none is undecided."""
    ledger = [as_entry(e) for e in ledger]
    lines = []
    for e in ledger:
        if e.adjusted_verdict not in verdict_words.UNDECIDED:
            continue
        # A claim the paper does not make (a row added since) is sized by its reference
        # effect, e.g. the paper's Eq. 4 gain for VQ-VAE; the sentence says which it is.
        effect = sizing_effect(e)
        whose = "the paper's" if e.paper is not None else "the reference"
        parts = [f"{e.adjusted_verdict}, ours {e.ours:+.3f} "
                 f"[{e.ci[0]:+.3f}, {e.ci[1]:+.3f}]"]
        if e.power is not None and effect is not None:
            parts.append(f"power {e.power:.0%} to detect {whose} {effect:+.3f} at "
                         f"these seeds")
        if e.mde is not None:
            parts.append(f"detects {e.mde:.3f} with 80% power")
        if e.seeds_needed and effect is not None:
            parts.append(f"{e.seeds_needed} seeds a row would detect {whose} effect")
        elif e.power_note:
            parts.append(e.power_note)
        lines.append(f"- **{e.id}**: " + "; ".join(parts) + ".")
    return "\n".join(lines)


def ledger_details(ledger: list[LedgerEntry | dict[str, Any]]) -> str:
    """Each claim's quantity, the paper's sentence and the power note, as a Markdown list."""
    ledger = [as_entry(e) for e in ledger]
    lines = []
    for e in ledger:
        note = f" {e.power_note[0].upper()}{e.power_note[1:]}." if e.power_note else ""
        if e.paper is None and e.reference_effect is None:
            note += f" It has no reference size ({e.reference})."
        elif e.paper is None:
            note += f" Its reference size in parentheses is {e.reference}."
        lines.append(f"- **{e.id}** ({e.quantity}): *{e.claim}*{note}")
    return "\n".join(lines)


def difference_sentence(results: dict[str, TableResult], a: str, b: str,
                        column: str = "avg", direction: int = +1) -> str:
    """`a` minus `b` on the same episodes, with its paired interval and the verdict on
    "a is higher" (direction +1) for each source, in Markdown."""
    from icil_paper import stats

    lines = []
    for source, result in results.items():
        xa, xb = result.outcomes(a, column), result.outcomes(b, column)
        if xa is None or xb is None:
            lines.append(f"- {source_label(source, result.preset)}: not run yet.")
            continue
        est = stats.paired_difference(xa, xb)
        claimed = "higher" if direction > 0 else "lower"
        lines.append(f"- {source_label(source, result.preset)}: '{a}' minus '{b}' = {est.value:+.3f} "
                     f"[{est.low:+.3f}, {est.high:+.3f}]; '{a}' is {claimed}: "
                     f"{stats.verdict(est, direction)}.")
    return "\n".join(lines)


VERDICT_COLOURS = verdict_words.COLOURS


def row_label(entry: LedgerEntry) -> str:
    """A forest plot's row: what the claim says in a few words, its id beside it."""
    label = CLAIM_LABELS.get(entry.id)
    return f"{label}  [{entry.id}]" if label else entry.id


def forest_plot(ledger: list[LedgerEntry | dict[str, Any]], title: str = "", verdict_key: str = "adjusted_verdict"):
    """One row per claim, labelled by what it says (`row_label`): our estimate and 95%
    interval (coloured by the verdict after Holm's correction), the paper's value as a black diamond and the zero line. Success
    differences share one panel; least-energy and correlation claims, on other scales, get
    their own. Rows a single-seed row reads are drawn dashed (their interval is the
    episodes' noise only)."""
    ledger = [as_entry(e) for e in ledger]
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    def panel_of(e):
        quantity = e.quantity.lower()
        return ("rank correlation" if "correlation" in quantity else
                "least energy" if "least energy" in quantity else
                "LDLJ difference" if "ldlj" in quantity else "success difference")

    panels = {}
    for e in ledger:
        panels.setdefault(panel_of(e), []).append(e)
    order = [p for p in ("success difference", "least energy", "LDLJ difference",
                         "rank correlation") if p in panels]
    heights = [len(panels[p]) for p in order]
    fig, axes = plt.subplots(len(order), 1, figsize=(10.5, 0.32 * sum(heights) + 1.2 * len(order) + 0.6),
                             gridspec_kw={"height_ratios": heights}, squeeze=False)
    for ax, name in zip(axes[:, 0], order, strict=True):
        entries = panels[name]
        y = np.arange(len(entries))[::-1]
        for yi, e in zip(y, entries, strict=True):
            verdict = getattr(e, verdict_key) or e.verdict
            colour = VERDICT_COLOURS.get(verdict, "black")
            if e.ours is not None:
                style = "--" if verdict == Verdict.TOO_FEW_SEEDS else "-"
                ax.plot(e.ci, [yi, yi], style, color=colour, lw=2.2)
                ax.plot(e.ours, yi, "o", color=colour, ms=5)
            if e.paper is not None:
                ax.plot(e.paper, yi, "D", color="black", ms=4, zorder=5)
            elif e.reference_effect is not None:  # the effect a claim of ours is read against
                ax.plot(e.reference_effect, yi, "D", mfc="white", mec="black", ms=4, zorder=5)
        ax.axvline(0, color="#57606a", lw=0.8)
        ax.set_yticks(y, [row_label(e) for e in entries], fontsize=8)
        ax.set_ylim(-0.7, len(entries) - 0.3)
        sides = {e.direction for e in entries}
        side = ("" if len(sides) > 1 else
                " (the paper claims above 0)" if sides == {1} else " (the paper claims below 0)")
        ax.set_xlabel(name + side, fontsize=8)
        ax.tick_params(axis="x", labelsize=8)
        ax.grid(axis="x", color="#eaeef2", lw=0.6)
    handles = [Line2D([], [], color=c, lw=2.2, ls="--" if v == Verdict.TOO_FEW_SEEDS else "-",
                      label=str(v)) for v, c in VERDICT_COLOURS.items() if v != Verdict.NOT_RUN]
    handles.append(Line2D([], [], color="black", marker="D", ls="", ms=4, label="the paper"))
    if any(e.paper is None and e.reference_effect is not None for e in ledger):
        handles.append(Line2D([], [], mfc="white", mec="black", marker="D", ls="", ms=4,
                              label="reference size (our claims)"))
    fig.legend(handles=handles, fontsize=7, loc="lower center", ncol=len(handles),
               frameon=False)
    axes[0, 0].set_title(title or "Claims: our 95% intervals and the paper's values", fontsize=10)
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    plt.close(fig)
    return fig


def design_sentence(preset: Preset) -> str:
    """The preset's seeds and episodes in words (never typed into a chapter): "3 training
    seeds for the ICRT rows and 1 for the other rows, 10 episodes per task and seed"."""
    t = preset.tables
    seeds = (f"{t.icrt_seeds} training seed{'s' if t.icrt_seeds != 1 else ''} for every row"
             if t.icrt_seeds == t.baseline_seeds else
             f"{t.icrt_seeds} training seed{'s' if t.icrt_seeds != 1 else ''} for the ICRT rows "
             f"and {t.baseline_seeds} for the other rows")
    scenes = ("seed k of every row on its own scene set k" if t.scenes_per_seed
              else "every seed on the same scenes")
    episodes = preset.eval.episodes_per_task
    tables: dict[str, list[str]] = {}  # table -> "5 a row" and "act 10" phrases
    for name, n in t.seeds_by_row().items():
        table, row = name.split(":", 1)
        phrase = f"{n} a row" if row == "*" else f"{row} {n}"
        tables.setdefault(table, []).insert(0 if row == "*" else len(tables.get(table, [])),
                                            phrase)
    for table, n in (("beyond", t.since_paper_seeds), ("official", t.official_seeds)):
        if n and n != t.icrt_seeds:
            tables.setdefault(table, []).insert(0, f"{n} a row")
    if tables:
        seeds += (" (Table I's rows, shared by Tables III-VI), except "
                  + "; ".join(f"table {table}: {', '.join(parts)}"
                              for table, parts in tables.items())
                  + " (a row that is one of Table I's keeps its seeds)")
    return (f"{seeds}, {episodes} episode{'s' if episodes != 1 else ''} per task and seed, "
            f"{scenes}")


OLDER_LEDGER = "older-code/claims.json"
"""Under `results/reference/`: the reference ledger as an older version of the code computed
it (its `made_by` names the commit), kept while the reference run is redone."""


def reference_freshness(preset_name: str = REFERENCE) -> dict[str, int]:
    """How many committed records of `preset_name` the current code still computes
    ("current") and how many an older version made ("stale", `stale_records`)."""
    stale = len(stale_records(preset_name))
    store = ResultsStore(preset_name)
    total = sum(1 for kind in ("train", "eval", "features") for _ in store.records(kind))
    return {"records": total, "current": total - stale, "stale": stale}


def older_ledger(preset_name: str = REFERENCE) -> tuple[dict[str, Any], list[dict]] | None:
    """(made_by, ledger) of the reference ledger an older version of the code computed, or
    None when there is none."""
    import json

    path = ResultsStore(preset_name).dir / OLDER_LEDGER
    if not path.exists():
        return None
    data = json.loads(path.read_text())
    return data["made_by"], data["claims"]


def reference_progress(path=None, older: bool = False) -> str:
    """Where the committed reference run stands, from its `cost.json`: the table cells
    finished of those planned, the machine time so far and the whole run's projected wall
    time against its target (`projection`); once every cell is done, what the whole run
    cost (`older`: every record is older code, so the run is the older protocol's). Empty
    when there is no cost.json."""
    import json
    from pathlib import Path

    path = Path(path) if path else ResultsStore(REFERENCE).dir / "cost.json"
    if not path.exists():
        return ""
    cost = json.loads(path.read_text())
    done, planned = cost.get("finished_cells", 0), cost.get("planned_cells", 0)
    if not planned:
        return ""
    hours = sum(s["elapsed_s"] for s in cost["sittings"]) / 3600
    sittings = f"{len(cost['sittings'])} sittings, {hours:.1f} hours of machine time"
    projection = cost.get("projection")
    whole = ""
    if projection:
        target = projection.get("target_wall_hours")
        against = f" (the target is {target:g} hours)" if target else ""
        whole = (f" At the CPU time its cells took, the whole run comes to "
                 f"{projection['wall_hours_at_2']:.1f} hours on an idle 2-core machine at "
                 f"two cells at a time{against}.")
    if done >= planned and older:
        return (f"The reference run of the older protocol finished all {planned} trained cells "
                f"({sittings}; `results/reference/cost.json`).{whole} Under the current "
                "protocol it is to be redone.")
    if done >= planned:
        return (f"The reference run is finished: all {planned} trained cells ({sittings}; "
                f"`results/reference/cost.json`).{whole}")
    return (f"The reference run is in progress: {done} of its {planned} trained cells have "
            f"finished ({sittings} so far; `results/reference/cost.json`).{whole} A claim "
            "whose rows are not all trained yet shows as *not run*.")


def decided_claims(ledger: list[LedgerEntry | dict[str, Any]]) -> str:
    """The claims decided after Holm's correction, by id: "Held: ... Did not hold: ...";
    empty when none is decided."""
    ledger = [as_entry(e) for e in ledger]
    parts = []
    for verdict, label in verdict_words.DECIDED_LABELS.items():
        ids = [e.id for e in ledger if e.adjusted_verdict == verdict]
        if ids:
            parts.append(f"{label}: {', '.join(ids)}.")
    return " ".join(parts)


def reference_summary(path=None) -> str:
    """The committed reference run's ledger in one sentence (`claims.summary_sentence`) and
    the claims it decided, or a sentence saying it is not there. Records made by older code
    are counted; while the current ledger still has claims not run, the older code's ledger
    is quoted too, labelled with its commit (once every claim is read, chapter 0 keeps it)."""
    from pathlib import Path

    from icil_paper.tables.claims import load_ledger, summary_sentence

    path = Path(path) if path else ResultsStore(REFERENCE).dir / "claims.json"
    if not path.exists():
        return f"The reference run's ledger is not there yet ({path.name} is missing)."
    ledger = load_ledger(path)
    text = f"{summary_sentence(ledger)} {decided_claims(ledger)}".strip()
    fresh = reference_freshness(REFERENCE)
    progress = reference_progress(path.with_name("cost.json"),
                                  older=fresh["stale"] == fresh["records"])
    if not fresh["stale"]:
        return f"{progress} {text}".strip()
    in_progress = any(e.verdict == Verdict.NOT_RUN for e in ledger)
    text = (f"{progress or 'The reference run is being redone with the current code.'} "
            f"{fresh['stale']} of its {fresh['records']} committed records were made by an "
            "older version of the code and are not used (chapter 0 lists them, with the "
            f"ledger that code computed). With the current code: {text[0].lower()}{text[1:]}")
    older = older_ledger(REFERENCE) if in_progress else None
    if older is not None:
        made_by, older_claims = older
        text += (f" With the older code (commit {made_by['commit'][:7]}), from those records: "
                 + summary_sentence(older_claims))
    return text


def answering_ledger(path=None) -> tuple[list, dict[str, Any] | None]:
    """(ledger, made_by) that answers the paper's questions on the first page: the committed
    reference ledger, or, while none of its claims has run under the current protocol, the
    ledger the older code computed (`older_ledger`) with its `made_by`; ([], None) when
    neither is there."""
    from pathlib import Path

    from icil_paper.tables.claims import as_entry, load_ledger

    path = Path(path) if path else ResultsStore(REFERENCE).dir / "claims.json"
    ledger = load_ledger(path) if path.exists() else []
    if any(e.run for e in ledger):
        return ledger, None
    older = older_ledger(REFERENCE)
    if older is None:
        return ledger, None
    made_by, claims = older
    return [as_entry(e) for e in claims], made_by


def reference_answers(path=None) -> str:
    """Sec. IV's three questions answered from the reference ledger (`answering_ledger`;
    `questions.answers_markdown`: one sentence each, with the numbers that carry it), saying
    so when the answers come from the older protocol's ledger."""
    from icil_paper.tables.questions import answers_markdown

    ledger, made_by = answering_ledger(path)
    if not ledger:
        return "The reference run's ledger is not there yet (claims.json is missing)."
    if made_by is None:
        return answers_markdown(ledger)
    return (f"No claim has run yet under the current protocol (the reference run is to be "
            f"redone). The older protocol's ledger (commit {made_by['commit'][:7]}: baselines "
            f"without the task's instruction, one demonstration set for every seed) answered:"
            f"\n\n" + answers_markdown(ledger))


def reference_bookkeeping(preset_name: str = REFERENCE) -> str:
    """Where the committed reference run stands (`reference_progress`) and how many of its
    records an older version of the code made (chapter 0 lists them)."""
    fresh = reference_freshness(preset_name)
    text = reference_progress(older=fresh["stale"] == fresh["records"])
    if fresh["stale"]:
        text += (f" {fresh['stale']} of its {fresh['records']} committed records were made by "
                 "an older version of the code and are not used (chapter 0 lists them).")
    return text.strip()


PRESET_ROLES = {"smoke": "the test suite (every path runs; numbers mean nothing)",
                "small": "CI and a laptop (numbers test the code, not the paper)",
                "reference": "numbers worth reading (committed under `results/reference/`)",
                "full": "the paper's scale: GPUs or a Ray cluster"}


def preset_table() -> str:
    """The presets' scale as a Markdown table, read from the presets themselves."""
    from icil_paper.config import PRESET_NAMES

    lines = ["| preset | meant for | training steps | demonstrations per task | episodes "
             "per task | training seeds (ICRT / other rows) |", "|---|---|---|---|---|---|"]
    for name in PRESET_NAMES:
        p = get_preset(name)
        lines.append(f"| `{name}` | {PRESET_ROLES.get(name, '')} | {p.train.steps} | "
                     f"{p.data.demos_per_task} | {p.eval.episodes_per_task} | "
                     f"{p.tables.icrt_seeds} / {p.tables.baseline_seeds} |")
    return "\n".join(lines)



def claims_figure(preset: Preset, table_id: str):
    """The forest plot of one table's claims in the reference run's ledger (this build's
    when the book is built with the reference preset); None when the table has no claim."""
    from icil_paper.tables.claims import claims_ledger

    p = get_preset(REFERENCE)
    entries = [e for e in claims_ledger(p, ResultsStore(p.name)) if e.table == table_id]
    if not entries:
        return None
    return forest_plot(entries, title=f"Table {table_id}'s claims, reference run: 95% "
                                      "intervals, the paper's values, the verdict after Holm")


def smoother_sentence(a: str, b: str, a_scores, b_scores, quantity: str) -> str:
    """"a minus b on <quantity>: +0.1 [-0.2, +0.4]: a is smoother" from per-trajectory
    scores (seeds, trajectories) of two tokenizers on the same trajectories (lower is
    smoother; `stats.paired_score_difference` and its verdict)."""
    from icil_paper import stats

    est = stats.paired_score_difference(a_scores, b_scores)
    words = verdict_words.SMOOTHER[stats.verdict(est, direction=-1)]
    return (f"{a} minus {b} on {quantity}: {est.value:+.4g} [{est.low:+.4g}, {est.high:+.4g}]"
            f": {a} is {words}")


def show_per_source(results: dict[str, TableResult], make_frame, describe=None) -> None:
    """One frame per source (`make_frame(result)`): the reference run's shown, this build's
    in a collapsed block when there is a reference beside it. `describe(result)` adds a
    sentence after the source's name."""
    from IPython.display import Markdown, display

    for source, result in results.items():
        extra = f": {describe(result)}" if describe else ""
        if source == BUILD and len(results) > 1:
            display(_collapsed(_build_summary(result) + extra, make_frame(result)))
            continue
        display(Markdown(f"**{source_label(source, result.preset)}**{extra}"))
        display(make_frame(result))


WHOLE_EPISODES = "icrt+lipvq (paper)"
RANDOM_WINDOWS = "lipvq, 32-step random windows"
"""The analysis table's two ways of training ICRT + LipVQ-VAE: whole episodes from step 0
(the default: the window the policy acts with) and ICRT's random 32-step query windows."""


def training_window_sentence(result: TableResult) -> str:
    """Chapter 02's comparison of the two training windows, from the analysis table: each
    row's success and the difference (whole episodes minus windows) with its 95% interval
    and verdict (`icil_paper.stats`), or a sentence saying the cells are not run yet."""
    from icil_paper import stats

    a, b = result.outcomes(WHOLE_EPISODES), result.outcomes(RANDOM_WINDOWS)
    if a is None or b is None:
        return ("The analysis table's two training windows have not run yet in this source "
                "(chapter 11 computes them).")
    ea, eb = result.estimate(WHOLE_EPISODES), result.estimate(RANDOM_WINDOWS)
    diff = stats.paired_difference(a, b, scenes=result.scenes(WHOLE_EPISODES, RANDOM_WINDOWS))
    verdict = stats.verdict(diff, direction=+1)
    return (f"Trained on whole episodes from step 0, ICRT + LipVQ-VAE succeeds "
            f"{ea.value:.2f} [{ea.low:.2f}, {ea.high:.2f}]; trained on random 32-step "
            f"windows, {eb.value:.2f} [{eb.low:.2f}, {eb.high:.2f}]. Whole episodes minus "
            f"windows: {diff.value:+.2f} [{diff.low:+.2f}, {diff.high:+.2f}] "
            f"({_seeds_words(result, WHOLE_EPISODES)}); that whole episodes help "
            f"{verdict_words.TRAINING_WINDOW[verdict]}.")


def _seeds_words(result: TableResult, row: str) -> str:
    cell = result.spec.row(row).cells["avg"]
    return f"{cell.seeds} training seed{'s' if cell.seeds != 1 else ''} a row"


# --------------------------------------------------------------------------- features and codebooks
def _codebook_rows(result: TableResult, column: str) -> list[tuple[str, Any]]:
    """(row label, its `column` cell spec) of every row whose policies' tokenizer has a
    codebook (`definitions.CODEBOOK_TOKENIZERS`), in the table's order."""
    from icil_paper.tables.definitions import CODEBOOK_TOKENIZERS

    out = []
    for row in result.spec.rows:
        cell = row.cells.get(column)
        tokenizer = cell.units[0].run.tokenizer if cell is not None and cell.units else None
        if tokenizer is not None and tokenizer.type in CODEBOOK_TOKENIZERS:
            out.append((row.label, cell))
    return out


def _per_seed_metrics(result: TableResult, label: str, cell_spec, column: str
                      ) -> list[tuple[int, dict[str, Any] | None]]:
    """(training seed, its features record's metrics or None while not run) per unit of a
    features cell, in seed order (`assemble` keeps the metrics in that order)."""
    units = sorted(cell_spec.units, key=lambda u: u.seed_index)
    cell = result.cell(label, column)
    metrics = cell.extra.get("metrics") if cell is not None and cell.estimate is not None else None
    return [(u.run.seed, metrics[i] if metrics else None) for i, u in enumerate(units)]


def codebook_frame(result: TableResult, column: str = "features"):
    """Codebook use of every VQ-family row (a tokenizer with a codebook), one line per
    training seed: the distinct codes its trained tokenizer gives the held-out trajectories
    of Table III (`codes used` of `K`, the codebook size), their share `usage`, and the
    perplexity of the code distribution (exp of its entropy: how many equally used codes
    would give it; rounded to 2 decimals). Values are None while a record is missing ("not
    run") or older than the perplexity measurement. Index (row, seed)."""
    import pandas as pd

    lines = []
    for label, cell_spec in _codebook_rows(result, column):
        for seed, m in _per_seed_metrics(result, label, cell_spec, column):
            m = m or {}
            lines.append({"row": label, "seed": seed, "codes used": m.get("codes_used"),
                          "K": m.get("codebook_size"), "usage": m.get("usage"),
                          "perplexity": m.get("perplexity"),
                          "status": "ok" if m else verdict_words.MISSING})
    frame = pd.DataFrame(lines, columns=["row", "seed", "codes used", "K", "usage",
                                         "perplexity", "status"])
    return frame.round({"usage": 3, "perplexity": 2}).set_index(["row", "seed"])


def codes_used_sentence(results: dict[str, TableResult], column: str = "features") -> str:
    """For each source, how many codes each codebook row used of its K on the held-out
    trajectories, and their perplexity (means over seeds), as a Markdown list: Fig. 5's
    sentence on its codebook sizes, generated from the features records."""
    lines = []
    for source, result in results.items():
        parts, missing = [], []
        for label, cell_spec in _codebook_rows(result, column):
            measured = [m for _, m in _per_seed_metrics(result, label, cell_spec, column)
                        if m and m.get("codes_used") is not None]
            if not measured:
                missing.append(label)
                continue
            used = float(np.mean([m["codes_used"] for m in measured]))
            size = measured[0]["codebook_size"]
            perplexities = [m["perplexity"] for m in measured if m.get("perplexity") is not None]
            seeds = "" if len(measured) == 1 else f", mean of {len(measured)} seeds"
            perplexity = (f", perplexity {np.mean(perplexities):.1f}" if perplexities else "")
            count = f"{used:.0f}" if len(measured) == 1 else f"{used:.1f}"
            parts.append(f"{label} used {count} of its {size} codes "
                         f"({used / size:.0%}{perplexity}{seeds})")
        name = source_label(source, result.preset)
        if not parts:
            lines.append(f"- {name}: not run yet.")
            continue
        text = "; ".join(parts)
        if missing:
            text += f"; {', '.join(missing)} not run yet"
        lines.append(f"- {name}: {text}.")
    return "\n".join(lines)


def feature_coverage(metrics: dict[str, Any]) -> dict[str, Any]:
    """What one features record scored: tasks scored and asked for (None in records older
    than the per-task sampling), trajectories, features, and the steps of each task."""
    steps = metrics.get("steps_per_task")
    return {"tasks_scored": len(metrics["tasks_scored"]) if "tasks_scored" in metrics else None,
            "tasks": len(metrics["tasks"]) if "tasks" in metrics else None,
            "trajectories": metrics["n_trajectories"], "features": metrics["n_features"],
            "steps_per_task": dict(steps) if steps else None}


def _coverage_words(c: dict[str, Any]) -> str:
    if c["tasks"] is None:
        return (f"{c['trajectories']} trajectories, {c['features']} features (an older record: "
                "the first features in task order, its tasks not recorded)")
    steps = c["steps_per_task"]
    common = max(set(steps.values()), key=list(steps.values()).count)
    others = [f"{t.split('/', 1)[-1]} {n}" for t, n in steps.items() if n != common]
    per_task = f"{common} steps each" + (f"; {', '.join(others)}" if others else "")
    return (f"{c['tasks_scored']} of its {c['tasks']} tasks ({per_task}), "
            f"{c['trajectories']} held-out trajectories, {c['features']} features")


def feature_sampling_sentence(results: dict[str, TableResult], column: str = "least_energy"
                              ) -> str:
    """For each source, what Table III's features records scored, per row and seed: tasks
    scored of the tasks asked for, steps per task, trajectories and features (Markdown,
    generated from the records; rows that scored the same are named together)."""
    lines = []
    for source, result in results.items():
        groups: dict[str, list[str]] = {}
        for row in result.spec.rows:
            cell = result.cell(row.label, column)
            if cell is None or cell.estimate is None:
                continue
            for m in cell.extra["metrics"]:
                words = _coverage_words(feature_coverage(m))
                if row.label not in groups.setdefault(words, []):
                    groups[words].append(row.label)
        name = source_label(source, result.preset)
        if not groups:
            lines.append(f"- {name}: not run yet.")
        elif len(groups) == 1:
            lines.append(f"- {name}: every row, each seed: {next(iter(groups))}.")
        else:
            lines.append(f"- {name}: " + "; ".join(f"{', '.join(rows)}, each seed: {words}"
                                                  for words, rows in groups.items()) + ".")
    return "\n".join(lines)


def show_codebook_use(results: dict[str, TableResult], column: str = "features") -> None:
    """Each source's `codebook_frame` (the reference run's shown, this build's in a collapsed
    block beside a reference), or one line for a source whose records are not there yet."""
    from IPython.display import Markdown, display

    for source, result in results.items():
        frame = codebook_frame(result, column)
        title = f"**{source_label(source, result.preset)}**"
        if frame.empty or (frame["status"] == verdict_words.MISSING).all():
            display(Markdown(f"{title}: codebook use not run yet."))
        elif source == BUILD and len(results) > 1:
            display(_collapsed(_build_summary(result), frame))
        else:
            display(Markdown(title))
            display(frame)
