"""Chapter 00's sources and its list of stale records.

    ledgers = chapter_ledgers(preset)        # {"reference run": (preset, ledger), "this build": ...}
    reference_ledger(ledgers)                # the reference run's entries
    show_stale_records(stale_records(REFERENCE), reference_freshness(REFERENCE),
                       older_ledger(REFERENCE))
    committed_design("I")                    # {"protocol": "kitchen", "seeds": {row: n}}

This build's ledger is written (`results/<preset>/claims.json`) before it is read; the
reference run's is read from its committed records and never written here.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from IPython.display import Markdown, display

from icil_paper.book.report import (
    BUILD,
    OLDER_RECORDS,
    REFERENCE,
    collapsed_markdown,
    ledger_frame,
)
from icil_paper.config import Preset, get_preset
from icil_paper.paper import claims_ledger, write_ledger
from icil_paper.planning.staged import as_run
from icil_paper.results import ResultsStore
from icil_paper.tables.claims import as_entry, read_ledger, summary_sentence
from icil_paper.tables.design import read_record

Ledgers = dict[str, tuple[Preset, list]]
"""{source: (its preset, its ledger entries)}, the reference run first."""


def chapter_ledgers(preset: Preset) -> Ledgers:
    """The ledgers chapter 0 shows: the reference run's (read from its committed records,
    when the build is another preset) and this build's (written to its store, then read)."""
    sources = [(BUILD, as_run(preset))]
    if preset.name != REFERENCE:
        sources.insert(0, (f"{REFERENCE} run", as_run(get_preset(REFERENCE))))
    ledgers = {}
    for source, p in sources:
        store = ResultsStore(p.name)
        if p.name == preset.name:
            write_ledger(p, store)
        if (read_record(store) or {}).get("protocol") == "kitchen":
            # the kitchen run's records: its tasks are retired, its ledger kept as computed
            entries = read_ledger(store.dir / "claims.json")["claims"]
            ledgers[f"{source} (kitchen suite, older protocol)"] = (
                p, [as_entry(e) for e in entries])
            continue
        ledgers[source] = (p, claims_ledger(p, store))
    return ledgers


def committed_design(table: str, preset_name: str = REFERENCE) -> dict[str, Any]:
    """The design the committed run of `preset_name` actually used for `table`, read from its
    design record (`results/<preset>/design.json`), never from the preset: {"protocol": the
    suite its records were made on ("kitchen" for the older protocol, else "metaworld"),
    "seeds": {row: the training seeds it reached at its last look}} ({} without looks)."""
    record = read_record(ResultsStore(preset_name)) or {}
    seeds: dict[str, int] = {}
    for look in record.get("looks", []):
        for name, n in look.get("rows", {}).items():
            t, row = name.split(":", 1)
            if t == table:
                seeds[row] = max(seeds.get(row, 0), int(n))
    return {"protocol": record.get("protocol", "metaworld"), "seeds": seeds}


def reference_ledger(ledgers: Ledgers) -> list:
    """The reference run's entries among `chapter_ledgers`' sources."""
    return next(ledger for p, ledger in ledgers.values() if p.name == REFERENCE)


NO_STALE = "None: every committed reference record is current."
"""What chapter 0 says when every committed reference record is current."""


def stale_summary(stale: Sequence[str], freshness: Mapping[str, int]) -> tuple[str, str]:
    """(the line of the collapsed block, the Markdown list inside it) for the stale records
    (`book.report.stale_records`; `freshness` from `book.report.reference_freshness`)."""
    line = (f"{freshness['stale']} of {freshness['records']} committed records are stale and "
            "not used. Open to see them.")
    return line, "\n".join(f"- `{name}`" for name in stale)


def older_ledger_heading(made_by: Mapping[str, Any], claims: Sequence[Any]) -> str:
    """The paragraph above the older code's ledger: its commit, why it is kept, and its
    counts of verdicts (`tables.claims.summary_sentence`)."""
    return (f"**The reference ledger as the older code (commit `{made_by['commit'][:7]}`) "
            f"computed it**, {made_by['why_kept']}. " + summary_sentence(claims))


def retired_sentence(retired: Mapping[str, int]) -> str:
    """What chapter 0 says of the records moved out of the reference store
    (`book.report.retired_records`, {commit: records}); empty when there are none."""
    if not retired:
        return ""
    commits = ", ".join(f"{n} by `{commit[:7]}`" for commit, n in retired.items())
    return (f"{sum(retired.values())} records made by older versions of the code ({commits}) "
            f"were moved out of the store to `results/reference/{OLDER_RECORDS}/`, each with "
            "its provenance; none is used above.")


def show_stale_records(stale: Sequence[str], freshness: Mapping[str, int],
                       older: tuple[Mapping[str, Any], list] | None,
                       retired: Mapping[str, int] | None = None) -> None:
    """Chapter 0's stale records, collapsed (or the line saying there are none), the records
    moved out of the store (`retired`, `book.report.retired_records`), then the ledger the
    older code computed from them (`book.report.older_ledger`) with its verdicts, where
    there are such records and that ledger is kept."""
    display(collapsed_markdown(*stale_summary(stale, freshness)) if stale
            else Markdown(NO_STALE))
    if retired:
        display(Markdown(retired_sentence(retired)))
    if not stale and not retired:
        return
    if older is not None:
        made_by, claims = older
        display(Markdown(older_ledger_heading(made_by, claims)))
        display(ledger_frame(claims, "verdicts"))
