"""The design a claims ledger is read under, and the record of it kept beside the results.

    design = ledger_design(preset, claims(preset))      # the preset's tables.* design fields
    design.family["IV-vq"], design.weights["IV-vq"]       # "primary", 0.8 / 6
    record = read_record(store)                           # results/<preset>/design.json

A design is fixed before the data: the looks (`tables.seed_stages`), the families and their
shares of the familywise 5% (weighted Holm's graph, `stats.graph_test`) and the
continuation rule. Claims that cannot be tested (rank correlations, or a smallest p-value
that cannot pass) are *descriptive*: reported, deciding nothing. `design.json` holds the
design a staged run was registered under and each look's seeds; one labelled "older" is
read under the older design (`older_design`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from icil_paper import stats, verdict_words
from icil_paper.config import Preset
from icil_paper.fileio import atomic_write_json, read_json

PRIMARY, SECONDARY, DESCRIPTIVE, ONE_FAMILY = "primary", "secondary", "descriptive", "one family"
"""The families a claim can be in (`ONE_FAMILY`: the older design's, every claim alike)."""

DESIGN_FILE = "design.json"
"""Beside a staged run's records: its design and the realised seeds of each look."""

DESIGN_FIELDS = ("seed_stages", "stage_budget_hours", "primary_claims", "family_weights",
                 "continuation_power", "episodes_per_task_by_suite")
"""The `TablesConfig` fields that make a design (the record keeps them)."""


@dataclass(frozen=True)
class Design:
    """The design of one ledger: families, shares of the level, looks, continuation rule."""

    family: dict[str, str]
    """Claim id -> `PRIMARY`, `SECONDARY`, `DESCRIPTIVE` or `ONE_FAMILY`."""
    weights: dict[str, float]
    """Claim id -> its initial share of the familywise level (they sum to 1)."""
    sequential: stats.SequentialDesign | None = None
    """The looks (None: one look at the seeds the rows have)."""
    continuation_power: float | None = None
    """The least conditional power at which a claim's rows go on (None: the older design)."""
    why: dict[str, str] = field(default_factory=dict)
    """Claim id -> why it is descriptive."""
    older: bool = False
    """True: the records were gathered under an earlier design (`older_design`)."""
    note: str = ""
    """What the design's record says of it (an older design's: why it is kept)."""

    @property
    def sizes(self) -> bool:
        """Whether sizes are decided (not under the older design)."""
        return not self.older

    def level(self, claim_id: str) -> float:
        """The claim's Bonferroni share of the level: ALPHA times its weight."""
        return stats.ALPHA * self.weights.get(claim_id, 0.0)

    def planning_level(self, claim_id: str) -> float:
        """The nominal level the claim's test must pass at the last look (for planning)."""
        level = self.level(claim_id)
        if self.sequential is None or level == 0:
            return level
        return float(self.sequential.nominal_level(level, len(self.sequential.stages) - 1))

    def to_dict(self) -> dict[str, Any]:
        """The design as `claims.json` states it."""
        families = {f: [c for c, g in self.family.items() if g == f]
                    for f in (PRIMARY, SECONDARY, DESCRIPTIVE, ONE_FAMILY)}
        return {"name": "older" if self.older else "current",
                "stages": list(self.sequential.stages) if self.sequential else [],
                "families": {f: ids for f, ids in families.items() if ids},
                "weights": {c: round(w, 6) for c, w in self.weights.items() if w},
                "continuation_power": self.continuation_power, "descriptive": self.why,
                **({"note": self.note} if self.note else {})}


def _descriptive(claim, weight: float, sequential) -> str | None:
    """Why a claim decides nothing (None: it is tested)."""
    if claim.compare.kind == "correlation":
        return verdict_words.DESCRIPTIVE_WHY["correlation"]
    floor, level = claim.compare.smallest_p, stats.ALPHA * weight
    if sequential is not None and floor > 0:
        floor = float(sequential.repeated_p_value(floor, len(sequential.stages) - 1))
    if floor > level:
        return verdict_words.DESCRIPTIVE_WHY["floor"].format(floor=floor, level=level)
    return None


def ledger_design(preset: Preset, claims: Sequence, record: dict[str, Any] | None = None
                  ) -> Design:
    """The preset's design over `claims`, or the older one for a `record` labelled so."""
    t = preset.tables
    sequential = stats.SequentialDesign(t.seed_stages) if t.seed_stages else None
    if record is not None and record.get("design") == "older":
        return replace(older_design(claims, sequential), note=record.get("why", ""))
    primary = set(t.primary_claims)  # none among `claims`: one family (Holm's procedure)
    family = {c.id: PRIMARY if c.id in primary else SECONDARY for c in claims}
    why: dict[str, str] = {}
    while True:  # a claim that leaves raises the others' shares: look again
        shares = dict(zip((PRIMARY, SECONDARY), t.family_weights, strict=True))
        members = {f: [c for c, g in family.items() if g == f] for f in shares}
        live = {f: s for f, s in shares.items() if members[f]}
        weights = {c: live[g] / sum(live.values()) / len(members[g]) if g in live else 0.0
                   for c, g in family.items()}
        left = {c.id: reason for c in claims if family[c.id] != DESCRIPTIVE
                and (reason := _descriptive(c, weights[c.id], sequential))}
        if not left:
            return Design(family, weights, sequential, t.continuation_power, why)
        why.update(left)
        family.update(dict.fromkeys(left, DESCRIPTIVE))


def older_design(claims: Sequence, sequential: stats.SequentialDesign | None) -> Design:
    """The reference records' design: one family, equal shares (Holm), sizes not decided."""
    return replace(one_family(claims, ONE_FAMILY), sequential=sequential, older=True)


def one_family(claims: Sequence, family: str = SECONDARY) -> Design:
    """A fixed design over `claims` alone, one family (Holm): `icil-paper compare`'s."""
    ids = [c.id for c in claims]
    return Design(dict.fromkeys(ids, family), dict.fromkeys(ids, 1 / len(ids)))


# --------------------------------------------------------------------------- the record
def record_path(store) -> Path:
    return Path(store.dir) / DESIGN_FILE


def read_record(store) -> dict[str, Any] | None:
    """The store's design record (`DESIGN_FILE`), None where it has none."""
    path = record_path(store)
    if not path.exists():
        return None
    return read_json(path, "a run's design record (design.json)",
                     "restore it from git, or delete it to register the design anew",
                     keys=("design", "tables", "looks"))


def new_record(preset: Preset) -> dict[str, Any]:
    """The record a staged run registers before its first cell: its design, no look yet."""
    return {"design": "current", "preset": preset.name,
            "tables": {f: list(v) if isinstance(v := getattr(preset.tables, f), tuple) else v
                       for f in DESIGN_FIELDS},
            "looks": []}


def write_record(store, record: dict[str, Any]) -> Path:
    path = record_path(store)
    atomic_write_json(path, record)
    return path
