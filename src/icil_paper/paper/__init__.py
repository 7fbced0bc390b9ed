"""The paper's results, one module each: its runs, its claims, the paper's numbers, its view.

    from icil_paper.paper import TABLES, table_spec, claims, claims_ledger, run_tables
    spec = table_spec(preset, "V")                 # Table V's TableSpec (paper/table_v.py)
    claims(preset)                                 # every claim, in the ledger's order
    ledger = claims_ledger(preset, store)          # every claim with its verdict
    run_tables(preset, ["I", "VI"], workers=2)     # computes what the store lacks

- `icrt_demo.py`     a small ICRT + LipVQ-VAE on one task, one cell, no claims (chapter 02)
- `table_i.py`       Table I, every policy on the Meta-World tasks (chapter 06)
- `table_ii.py`      Table II, ACT with each tokenizer on ManiSkill (chapter 07)
- `table_iii.py`     Table III, the latents' smoothness, with Figs. 1 and 4 (chapter 08)
- `table_iv.py`      Table IV, Eq. 4's ablation, with Fig. 5, the codebook size (chapter 09)
- `table_v.py`       Table V, sim-to-real on our perturbed Kinova3 stand-in (chapter 10)
- `table_vi.py`      Table VI, cross-dataset, and each row's shift from Table I (chapter 10)
- `table_vii.py`     Table VII, zero-shot on ML45's held-out tasks (chapter 10)
- `prompt_ablation.py`   does the prompt carry the task? (chapters 06 and 10)
- `analysis.py`      is it smoothness? Eq. 4, latent scale and collapse (chapters 11 and 02)
- `since_paper.py`   the tokenizers since the paper, the `beyond` table (chapter 12)
- `official.py`      the paper against its official code (chapter 13)

Each declares `spec(preset) -> TableSpec`, its `claims(preset)`, the paper's numbers as
printed and what its chapter shows; the later tables reuse Table I's trained policies.
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
    """Refuse, before any work, a `tables.row_seeds` entry that names no table or no row of
    its table (UnknownNameError with a "did you mean"); Fig. 5's rows are its codebook sizes,
    Table I's include the rows of the tables that share its runs (Table IV's Lip-MLP)."""
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
    """Every claim, in the ledger's order: the paper's, in the order of its Sec. IV, then
    those of our own (`beyond`: does Eq. 4 help every quantizer?; and do smoother latents go
    with smoother motion?)."""
    paper = [c for result in _PAPER_CLAIMS for c in result.claims(preset) if not c.own]
    ours = [c for result in _OWN_CLAIMS for c in result.claims(preset) if c.own]
    return paper + ours


def ledger_design_of(preset: Preset, store: ResultsStore | None = None) -> Design:
    """The design the records of `store` are read under (`tables.design.ledger_design`): the
    preset's, or the older one where the store's design record says its records are."""
    store = store or ResultsStore(preset.name)
    return ledger_design(preset, claims(preset), read_record(store))


def claims_ledger(preset: Preset, store: ResultsStore | None = None) -> list[LedgerEntry]:
    """Every claim evaluated on the records of `store` (default: the preset's), decided
    under the design of those records (`ledger_design_of`; `tables.claims.ledger_entries`)."""
    store = store or ResultsStore(preset.name)
    every = claims(preset)
    needed = {c.table for c in every} | {"I"}
    tables = {t: assemble(table_spec(preset, t), store) for t in sorted(needed)}
    return ledger_entries(preset, every, tables, ledger_design_of(preset, store))


def write_ledger(preset: Preset, store: ResultsStore | None = None) -> str:
    """Write `results/<preset>/claims.json` (atomically), its design stated above the
    entries, and return its path."""
    store = store or ResultsStore(preset.name)
    path = store.dir / "claims.json"
    record = DESIGN_FILE if read_record(store) is not None else None
    atomic_write_json(path, ledger_file(preset, claims_ledger(preset, store),
                                        ledger_design_of(preset, store), record))
    return str(path)


def run_tables(preset: Preset, table_ids: Sequence[str] | None = None, executor: str = "local",
               workers: int | None = None, ray_address: str | None = None,
               gpus_per_cell: float = 0.0, progress: bool = True) -> dict[str, Any]:
    """Compute every missing record of the chosen tables (default: all) as grid cells
    (`tables.cells`: each policy trained once for every table that reads it). Each cell asks for one CPU and `gpus_per_cell` GPUs (Ray schedules by them).
    Returns the grid's summaries by run key."""
    ids = list(table_ids or TABLES)
    return run_specs(preset, [table_spec(preset, t) for t in ids], executor=executor,
                     workers=workers, ray_address=ray_address, gpus_per_cell=gpus_per_cell,
                     progress=progress)
