"""Chapter 00's sources.

    ledgers = chapter_ledgers(preset)        # {"reference run": (preset, ledger), "this build": ...}
    reference_ledger(ledgers)                # the reference run's entries
    committed_design("I")                    # {"protocol": "kitchen", "seeds": {row: n}}

This build's ledger is written (`results/<preset>/claims.json`) before it is read; the
reference run's is read from its committed records and never written here.
"""

from __future__ import annotations

from typing import Any

from icil_paper.book.report import REFERENCE, run_sources
from icil_paper.config import Preset
from icil_paper.paper import claims_ledger, write_ledger
from icil_paper.results import ResultsStore
from icil_paper.tables.claims import as_entry, read_ledger
from icil_paper.tables.design import read_record

Ledgers = dict[str, tuple[Preset, list]]
"""{source: (its preset, its ledger entries)}, the reference run first."""


def chapter_ledgers(preset: Preset) -> Ledgers:
    """The ledgers chapter 0 shows, by source (this build's written to its store first)."""
    ledgers = {}
    for source, p in run_sources(preset):
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
    """The design the committed run of `preset_name` used for `table`, from its design
    record: {"protocol": "kitchen" or "metaworld", "seeds": {row: seeds at its last look}}."""
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
