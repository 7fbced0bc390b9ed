"""The paper's results, one module each: its runs, its claims, the paper's numbers, its view.

    from icil_paper.paper import TABLES, table_spec, claims, claims_ledger, run_tables
    spec = table_spec(preset, "V")                 # Table V's TableSpec (paper/table_v.py)
    claims(preset)                                 # every claim, in the ledger's order
    ledger = claims_ledger(preset, store)          # every claim with its verdict
    run_tables(preset, ["I", "VI"], workers=2)     # computes what the store lacks

Each module (`table_i` .. `table_vii`, `icrt_demo`, `prompt_ablation`, `analysis`,
`since_paper`, `official`) declares `spec(preset) -> TableSpec`, its `claims(preset)`, the
paper's numbers as printed and what its chapter shows.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from icil_paper.config import Preset
from icil_paper.fileio import atomic_write_json
from icil_paper.paper import (
    analysis,
    icrt_demo,
    official,
    prompt_ablation,
    since_paper,
    table_i,
    table_ii,
    table_iii,
    table_iv,
    table_v,
    table_vi,
    table_vii,
)
from icil_paper.registry import check_name
from icil_paper.results import ResultsStore
from icil_paper.tables.assemble import assemble
from icil_paper.tables.cells import run_specs
from icil_paper.tables.claims import Claim, LedgerEntry, ledger_entries, ledger_file
from icil_paper.tables.design import DESIGN_FILE, Design, ledger_design, read_record
from icil_paper.tables.spec import TableSpec

TABLES: dict[str, Callable[[Preset], TableSpec]] = {
    "icrt": icrt_demo.spec,
    "I": table_i.spec, "II": table_ii.spec, "III": table_iii.spec, "IV": table_iv.spec,
    "V": table_v.spec, "VI": table_vi.spec, "VII": table_vii.spec, "fig5": table_iv.fig5_spec,
    "prompt": prompt_ablation.spec, "analysis": analysis.spec, "beyond": since_paper.spec,
    "official": official.spec,
}
"""Every table by id, in the order the book shows them."""

PAPER_TABLES = {
    "I": table_i.TABLE_I_ROBOCASA, "II": table_ii.TABLE_II_MANISKILL,
    "III": table_iii.TABLE_III_SMOOTHNESS, "IV": table_iv.TABLE_IV_LIPSCHITZ,
    "V": table_v.TABLE_V_SIM_TO_REAL, "VI": table_vi.TABLE_VI_CROSS_DATASET,
    "VII": table_vii.TABLE_VII_ZERO_SHOT, "fig5": table_iv.FIG5_CODEBOOK_SIZE,
}
"""Every table of the paper by its number in the paper's source (values as printed)."""

_PAPER_CLAIMS = (table_i, table_ii, table_iii, table_iv, table_v, table_vi, table_vii)
_OWN_CLAIMS = (since_paper, table_iii)

CLAIM_LABELS = {claim_id: words for result in (*_PAPER_CLAIMS, since_paper)
                for claim_id, words in result.CLAIM_LABELS.items()}
"""What each claim says, in a few words (the forest plot's rows, the introduction)."""


def table_spec(preset: Preset, table_id: str) -> TableSpec:
    """The TableSpec of one table (UnknownNameError listing the ids otherwise)."""
    return TABLES[check_name("table", table_id, TABLES)](preset)


def check_row_seeds(preset: Preset) -> None:
    """UnknownNameError for a `tables.row_seeds` entry naming no table or no row of it."""
    for name in preset.tables.seeds_by_row():
        table, row = name.split(":", 1)
        check_name("tables.row_seeds table", table, TABLES)
        if row == "*":
            continue
        if table == "fig5":
            rows = [str(s) for s in preset.tables.codebook_sizes]
        else:
            rows = [r.label for r in table_spec(preset, table).rows]
            if table == "I":
                rows += [r.label for r in table_spec(preset, "IV").rows]
        check_name(f"tables.row_seeds row of table {table}", row, list(dict.fromkeys(rows)))


def claims(preset: Preset) -> list[Claim]:
    """Every claim in the ledger's order: the paper's (as in its Sec. IV), then our own."""
    paper = [c for result in _PAPER_CLAIMS for c in result.claims(preset) if not c.own]
    ours = [c for result in _OWN_CLAIMS for c in result.claims(preset) if c.own]
    return paper + ours


def ledger_design_of(preset: Preset, store: ResultsStore | None = None) -> Design:
    """The design the records of `store` are read under (`tables.design.ledger_design`)."""
    store = store or ResultsStore(preset.name)
    return ledger_design(preset, claims(preset), read_record(store))


def claims_ledger(preset: Preset, store: ResultsStore | None = None) -> list[LedgerEntry]:
    """Every claim evaluated on the records of `store` (default: the preset's)."""
    store = store or ResultsStore(preset.name)
    every = claims(preset)
    needed = {c.table for c in every} | {"I"}
    tables = {t: assemble(table_spec(preset, t), store) for t in sorted(needed)}
    return ledger_entries(preset, every, tables, ledger_design_of(preset, store))


def write_ledger(preset: Preset, store: ResultsStore | None = None) -> str:
    """Write `results/<preset>/claims.json` (atomically) and return its path."""
    store = store or ResultsStore(preset.name)
    path = store.dir / "claims.json"
    record = DESIGN_FILE if read_record(store) is not None else None
    atomic_write_json(path, ledger_file(preset, claims_ledger(preset, store),
                                        ledger_design_of(preset, store), record))
    return str(path)


def run_tables(preset: Preset, table_ids: Sequence[str] | None = None, executor: str = "local",
               workers: int | None = None, ray_address: str | None = None,
               gpus_per_cell: float = 0.0, progress: bool = True) -> dict[str, Any]:
    """Compute every missing record of the chosen tables (default: all) as cells
    (`tables.cells.run_specs`); returns their summaries by run key."""
    ids = list(table_ids or TABLES)
    return run_specs(preset, [table_spec(preset, t) for t in ids], executor=executor,
                     workers=workers, ray_address=ray_address, gpus_per_cell=gpus_per_cell,
                     progress=progress)
