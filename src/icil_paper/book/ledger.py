"""Chapter 00's sources.

    ledgers = chapter_ledgers(preset)        # {"reference run": (preset, ledger), "this build": ...}
    reference_ledger(ledgers)                # the reference run's entries
    committed_design("I")                    # {"protocol": "kitchen", "seeds": {row: n}}
    for q in QUESTIONS: q.decides, q.beside  # Sec. IV's questions and the claims answering them

This build's ledger is written (`results/<preset>/claims.json`) before it is read; the
reference run's is read from its committed records and never written here.
"""

from __future__ import annotations

from dataclasses import dataclass
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


@dataclass(frozen=True)
class Question:
    """One of Sec. IV's questions and the claims of the ledger that answer it."""

    key: str
    """"Q1", "Q2" or "Q3", as the paper numbers them."""
    text: str
    """The question in plain words."""
    decides: tuple[str, ...]
    """The claims whose verdicts answer it."""
    beside: tuple[str, ...] = ()
    """Claims quoted beside them (they do not change the answer)."""


QUESTIONS = (
    Question("Q1", "Does the action tokenizer matter, and is LipVQ-VAE the best one?",
             ("I-lipvq-best", "II-lipvq-best", "I-tokenizer-gap"), ("I-lipvq-vs-bc",)),
    Question("Q2", "Does smoothness explain it?",
             ("III-lipvq-smoothest", "III-smoother-succeeds", "IV-vq")),
    Question("Q3", "Does it transfer from simulation to the real robot, across data sets and "
             "to unseen tasks?",
             ("V-lipvq-vs-bc", "V-lipvq-vs-bin"), ("VI-lipvq-best", "VII-lipvq-vs-bc")),
)
"""Sec. IV's Q1-Q3 (Q3 is sim-to-real in the paper; Tables VI and VII are quoted beside)."""
