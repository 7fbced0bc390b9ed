"""The claims engine: a claim of the paper checked against our numbers, and the ledger.

    from icil_paper.paper import claims_ledger, write_ledger
    ledger = claims_ledger(preset, store)          # list of LedgerEntry, one per claim
    write_ledger(preset, store)                   # results/<preset>/claims.json
    summary(ledger)                               # counts of the decisions, by family

A claim is a quantity with a claimed direction (e.g. the difference of two rows' average
success, claimed above 0). Each entry holds the paper's value, ours with its 95% interval
(the training seed as the unit), `verdict` (the interval alone), `adjusted_verdict` (the
decision to quote, under `tables.design`), `size`, and `mde`, `power`, `seeds_needed`.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, fields, replace
from functools import partial
from typing import Any

import numpy as np

from icil_paper import stats, verdict_words
from icil_paper.config import Preset
from icil_paper.estimates import Size, Verdict
from icil_paper.fileio import UnreadableFileError, read_json
from icil_paper.metrics import MOTION_MEASURES, SMOOTHER
from icil_paper.tables.assemble import TableResult
from icil_paper.tables.design import DESCRIPTIVE, Design, ledger_design, one_family

MAX_SEEDS = 1000
"""`seeds_needed` searches up to this many seeds a row."""

VERDICTS = verdict_words.LEDGER_ORDER


@dataclass(frozen=True)
class Comparison:
    """`a` minus the one other row on the same episodes, or best of k with several `others`."""

    table: str
    a: str
    others: tuple[str, ...]
    column: str = "avg"

    @property
    def kind(self) -> str:
        return "score" if self.column == "least_energy" else "success"

    smallest_p = 0.0
    """The smallest p-value its test can reach."""

    @property
    def pool(self) -> str:
        """The quantity whose per-seed variances a one-seed row borrows."""
        return "least_energy" if self.kind == "score" else "success"

    @property
    def sign(self) -> int:
        """The better direction of a row's value (least energy: lower is smoother)."""
        return -1 if self.kind == "score" else +1

    @property
    def rows(self) -> tuple[str, ...]:
        return (self.a, *self.others)

    def row(self, tables: dict[str, TableResult], label: str) -> np.ndarray | None:
        """One row's outcomes (scores where `kind` is "score"); None: not run."""
        return tables[self.table].outcomes(label, self.column)

    def data(self, tables: dict[str, TableResult]) -> list[np.ndarray] | None:
        data = [self.row(tables, label) for label in self.rows]
        return None if any(d is None for d in data) else data

    def estimate(self, tables: dict[str, TableResult]) -> stats.Estimate | None:
        data = self.data(tables)
        if data is None:
            return None
        if self.kind == "score":
            difference = stats.paired_score_difference
        else:
            difference = partial(stats.paired_difference, scenes=self.scenes(tables))
        if len(self.others) == 1:
            return difference(*data)
        return stats.best_of(data[0], data[1:], difference, self.sign)

    def scenes(self, tables: dict[str, TableResult]) -> str:
        """"per_seed" where the rows' seeds are paired by scene set (Welch's t for scores)."""
        if self.kind == "score":
            return "shared"
        return tables[self.table].scenes(*self.rows, column=self.column)


@dataclass(frozen=True)
class MotionComparison(Comparison):
    """A `Comparison` of a motion measure (`metrics.MOTION_MEASURES`) of the same episodes."""

    measure: str = "ldlj"
    kind = "score"

    @property
    def pool(self) -> str:
        return self.measure

    @property
    def sign(self) -> int:
        return SMOOTHER[self.measure]

    def row(self, tables: dict[str, TableResult], label: str) -> np.ndarray | None:
        return tables[self.table].motion_scores(label, self.column, self.measure)


@dataclass(frozen=True)
class Correlation:
    """Spearman correlation across `rows` of Table III's least energy and Table I's success."""

    rows: tuple[str, ...]
    table: str = "III"
    kind: str = "correlation"
    n_boot: int = 2000
    table_i_kind = "success"
    """What Table I's quantity is to `stats.rank_correlation`."""

    @property
    def smallest_p(self) -> float:
        return 1 / self.n_boot

    def table_i(self, tables: dict[str, TableResult], row: str) -> np.ndarray | None:
        return tables["I"].outcomes(row, "avg")

    def data(self, tables: dict[str, TableResult]):
        smooth = [tables["III"].outcomes(r, "least_energy") for r in self.rows]
        other = [self.table_i(tables, r) for r in self.rows]
        return None if any(x is None for x in smooth + other) else (smooth, other)

    def estimate(self, tables: dict[str, TableResult]) -> stats.Estimate | None:
        data = self.data(tables)
        return None if data is None else stats.rank_correlation(
            *data, ("score", self.table_i_kind), n_boot=self.n_boot)


@dataclass(frozen=True)
class MotionCorrelation(Correlation):
    """Spearman correlation across `rows` of Table III's least energy and Table I's motion
    `measure` (a joint bootstrap)."""

    measure: str = "ldlj"
    table_i_kind = "score"

    def table_i(self, tables: dict[str, TableResult], row: str) -> np.ndarray | None:
        return tables["I"].motion_scores(row, "avg", self.measure)


@dataclass(frozen=True)
class Claim:
    """One claim of the paper and how it is checked."""

    id: str
    """Short identifier, e.g. `I-lipvq-vs-bc`."""
    table: str
    """The table it is about (`I` .. `VII`, `fig5`)."""
    claim: str
    """The paper's sentence (or its gist where the sentence spans a paragraph)."""
    quantity: str
    """What is compared, in words."""
    direction: int
    """+1: claimed above 0; -1: claimed below 0."""
    compare: Comparison | Correlation | MotionComparison | MotionCorrelation
    """The rows it reads and how they are compared."""
    paper_value: Callable[[], float] | None
    """The quantity from the paper's numbers (own claims: the reference effect); None: none."""
    own: bool = False
    """A claim of this companion, not of the paper."""
    reference: str = ""
    """What the reference effect of an own claim is."""


@dataclass
class LedgerEntry:
    """One claim of the ledger as `claims.json` stores it (`to_dict`, `from_dict`); unknown
    stored fields are kept in `extra` and read as attributes."""

    id: str = ""
    claim: str = ""
    """The paper's sentence (or its gist)."""
    table: str = ""
    quantity: str = ""
    """What is compared, in words."""
    direction: int = +1
    """+1: claimed above 0; -1: claimed below 0."""
    source: str = "the paper"
    """"the paper" or "ours" (a claim of this companion)."""
    family: str | None = None
    """"primary", "secondary", "descriptive" or "one family" (`tables.design`)."""
    weight: float | None = None
    """The claim's share of the familywise level before any claim is decided."""
    paper: float | None = None
    """The same quantity from the paper's numbers."""
    reference_effect: float | None = None
    """For a claim with no `paper` value: the effect it is sized against, if any."""
    reference: str | None = None
    """What `reference_effect` is."""
    ours: float | None = None
    ci: list[float] | None = None
    """Our 95% interval [low, high]."""
    n: int | None = None
    episodes: int | None = None
    seeds: dict[str, int] | None = None
    """Row -> its training seeds."""
    method: str | None = None
    p_value: float | None = None
    verdict: Verdict | str = Verdict.NOT_RUN
    size: Size | str | None = None
    """The decided size against the paper's effect."""
    mde: float | None = None
    power: float | None = None
    seeds_needed: int | None = None
    variance_from: dict[str, str] | None = None
    power_note: str | None = None
    plan: dict[str, Any] | None = None
    """The power fields' `variance` (per seed), `paired` and nominal `level`."""
    adjusted_verdict: Verdict | str | None = None
    """The decision under the ledger's design (the one to quote)."""
    extra: dict[str, Any] = field(default_factory=dict)
    """Fields this class does not name, in stored order."""
    order: tuple[str, ...] = field(default=(), repr=False, compare=False)
    """The stored keys in their stored order (empty: the order of the fields)."""

    def __getattr__(self, name: str) -> Any:
        extra = self.__dict__.get("extra")
        if extra is not None and name in extra:
            return extra[name]
        raise AttributeError(f"ledger entry has no field {name!r}")

    @property
    def run(self) -> bool:
        return self.verdict != Verdict.NOT_RUN

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> LedgerEntry:
        names = {f.name for f in fields(cls)} - {"extra", "order"}
        known = {k: v for k, v in data.items() if k in names}
        for key, enum in (("verdict", Verdict), ("adjusted_verdict", Verdict), ("size", Size)):
            if known.get(key) in set(enum):  # a stored value: its enum member
                known[key] = enum(known[key])
        return cls(**known, extra={k: v for k, v in data.items() if k not in names},
                   order=tuple(data))

    def to_dict(self) -> dict[str, Any]:
        """The stored keys in their stored order (built by hand: every field, then `extra`)."""
        order = self.order or [f.name for f in fields(self)][:-2] + list(self.extra)
        return {k: (self.extra[k] if k in self.extra else getattr(self, k)) for k in order}


def as_entry(entry: LedgerEntry | dict[str, Any]) -> LedgerEntry:
    """A ledger entry, or a stored one (a dict), as a `LedgerEntry`."""
    return entry if isinstance(entry, LedgerEntry) else LedgerEntry.from_dict(entry)


# --------------------------------------------------------------------------- helpers
def diff(table: str, a: str, b: str, column: str = "avg") -> Comparison:
    return Comparison(table, a, (b,), column)


def margin(table: str, a: str, others: Sequence[str], column: str = "avg") -> Comparison:
    return Comparison(table, a, tuple(others), column)


def paper_diff(rows: dict, a: str, b: str, column: str = "avg"):
    return lambda: rows[a][column] - rows[b][column]


def paper_margin(rows: dict, a: str, others: Sequence[str], column: str = "avg"):
    return lambda: rows[a][column] - max(rows[o][column] for o in others)


def versus(table: str, paper: dict, a: str, b: str | Sequence[str], claim_id: str, claim: str,
           quantity: str, **options) -> Claim:
    """The claim that row `a` of `table` beats row `b`, or the best of several rows `b`, on
    average success; the paper's number from its rows `paper`."""
    one = isinstance(b, str)
    return Claim(claim_id, table, claim, quantity, +1,
                 diff(table, a, b) if one else margin(table, a, b),
                 paper_diff(paper, a, b) if one else paper_margin(paper, a, b), **options)


# --------------------------------------------------------------------------- the ledger
def _pooled_variances(tables: dict[str, TableResult]) -> dict[tuple[str, str], float]:
    """(table or "*", quantity) -> the mean per-seed variance of its multi-seed rows: what
    a one-seed row borrows for the power analysis."""
    pooled: dict[tuple[str, str], list[float]] = {}

    def add(table_id: str, quantity: str, data, kind: str) -> None:
        var = stats.seed_variance(data, kind)
        if var is not None:
            pooled.setdefault((table_id, quantity), []).append(var)
            pooled.setdefault(("*", quantity), []).append(var)

    for table_id, result in tables.items():
        for (row, column), entry in result.entries.items():
            if entry.data is None or column not in ("avg", "least_energy"):
                continue
            if column == "least_energy":
                add(table_id, "least_energy", entry.data, "score")
                continue
            add(table_id, "success", entry.data, "success")
            for measure in MOTION_MEASURES:
                scores = result.motion_scores(row, column, measure)
                if scores is not None:
                    add(table_id, measure, scores, "score")
    return {k: float(np.mean(v)) for k, v in pooled.items()}


_POWER_FIELDS = ("mde", "power", "seeds_needed", "variance_from", "power_note", "plan")
_ESTIMATE_FIELDS = ("ours", "ci", "n", "episodes", "seeds", "method", "p_value", "verdict",
                    "size")


def _power(claim: Claim, estimate: stats.Estimate, tables: dict[str, TableResult],
           pooled: dict[tuple[str, str], float], effect: float | None,
           design: Design) -> dict[str, Any]:
    """mde, power and seeds_needed with the variance the claim's test reads, at
    `Design.planning_level`; best of k: against the closest other row."""
    out: dict[str, Any] = dict.fromkeys(_POWER_FIELDS)
    compare = claim.compare
    if design.family[claim.id] == DESCRIPTIVE:
        return {**out, "power_note": f"not planned: {design.why[claim.id]}"}
    if not isinstance(compare, Comparison):
        return {**out, "power_note": "not planned: a rank correlation across rows has no "
                                     "closed form"}
    data = dict(zip(compare.rows, compare.data(tables), strict=True))
    other = compare.others[0]
    if estimate.components:
        j = int(np.argmin([claim.direction * c.value for c in estimate.components]))
        other = compare.others[j]
    a, b = data[compare.a], data[other]
    seeds = min(len(a), len(b))
    paired = compare.scenes(tables) == "per_seed" and seeds >= 2
    if paired:
        var = stats.seed_variance(a, compare.kind, b)
        source = dict.fromkeys((compare.a, other), "own seeds, paired")
    else:  # each row's own variance, else the one its table's (or the ledger's) rows pool
        own = {label: stats.seed_variance(x, compare.kind) for label, x in ((compare.a, a), (other, b))}
        borrow = {(compare.table, compare.pool): f"pooled over Table {compare.table}'s multi-seed rows",
                  ("*", compare.pool): "pooled over the ledger's rows"}
        key = next((k for k in borrow if k in pooled), None)
        if key is None and None in own.values():
            return {**out, "power_note": "no row with two seeds to measure a variance"}
        source = {label: "own seeds" if v is not None else borrow[key] for label, v in own.items()}
        var = sum(v if v is not None else pooled[key] for v in own.values())
    level = design.planning_level(claim.id)
    out.update(variance_from=source, plan={"variance": var, "paired": paired, "level": level})
    if seeds >= 2:
        out["mde"] = stats.minimum_detectable(var, seeds, alpha=level, paired=paired)
    if effect is None:
        out["power_note"] = "no reference effect (no number to plan for): only the mde"
    elif claim.direction * effect > 0:
        if seeds >= 2:
            out["power"] = stats.power_at(var, seeds, effect, alpha=level, paired=paired)
        out["seeds_needed"] = stats.seeds_needed(var, effect, alpha=level, paired=paired,
                                                 max_seeds=MAX_SEEDS)
        if out["seeds_needed"] is None:
            out["power_note"] = (f"the paper's effect ({effect:+.3g}) would need more than "
                                 f"{MAX_SEEDS} seeds a row")
    else:
        out["power_note"] = "the paper's own value is not on the claimed side: nothing to plan"
    return out


def _evaluate(claim: Claim, tables: dict[str, TableResult],
              pooled: dict[tuple[str, str], float], design: Design
              ) -> tuple[dict[str, Any], Any]:
    """One ledger entry (without decision and size) and its estimate (None when not run)."""
    estimate = claim.compare.estimate(tables)
    paper_value = (None if claim.paper_value is None
                   else round(float(claim.paper_value()), 4))
    entry: dict[str, Any] = {"id": claim.id, "claim": claim.claim, "table": claim.table,
                             "quantity": claim.quantity, "direction": claim.direction,
                             "source": "ours" if claim.own else "the paper",
                             "family": design.family[claim.id],
                             "weight": round(design.weights[claim.id], 6),
                             "paper": None if claim.own else paper_value}
    if claim.own or paper_value is None:
        entry.update(reference_effect=paper_value, reference=claim.reference)
    if estimate is None:
        entry.update(dict.fromkeys(_ESTIMATE_FIELDS + _POWER_FIELDS), verdict=Verdict.NOT_RUN)
        return entry, None
    test = stats.decision_p_value(estimate, claim.direction)
    entry.update(ours=estimate.value, ci=[estimate.low, estimate.high], n=estimate.n,
                 episodes=estimate.episodes,
                 seeds=dict(zip(claim.compare.rows, estimate.seeds, strict=True)),
                 method=estimate.method, p_value=None if test is None else test[0],
                 verdict=stats.verdict(estimate, direction=claim.direction), size=None,
                 **_power(claim, estimate, tables, pooled, paper_value, design))
    return entry, estimate


def ledger_entries(preset: Preset, chosen: Sequence[Claim], tables: dict[str, TableResult],
                   design: Design | None = None) -> list[LedgerEntry]:
    """`chosen` claims evaluated on the assembled `tables` (each claim's and Table I),
    decided under `design` (default: `tables.design.ledger_design`)."""
    design = design or ledger_design(preset, chosen)
    entries = evaluate_claims(chosen, tables, design, preset.tables.stage_stops)
    return [LedgerEntry.from_dict(e) for e in entries]


def evaluate_claims(chosen: Sequence[Claim], tables: dict[str, TableResult],
                    design: Design | None = None, stops: Sequence[str] = ()
                    ) -> list[dict[str, Any]]:
    """Ledger entries (dicts) of `chosen` claims decided under `design`, by default Holm's
    procedure over `chosen` alone (`tables.design.one_family`; `icil-paper compare`); a
    claim of `stops` was stopped by a staged run's budget."""
    design = design or one_family(chosen)
    pooled = _pooled_variances(tables)
    entries, estimates = zip(*(_evaluate(c, tables, pooled, design) for c in chosen),
                             strict=True)
    if design.sequential is None:
        _fixed(list(chosen), list(entries), list(estimates), design)
    else:
        _sequential(list(chosen), list(entries), tables, design, stops)
    return list(entries)


def ledger_file(preset: Preset, entries: Sequence[LedgerEntry], design: Design | None = None,
                record: str | None = None) -> dict[str, Any]:
    """What `claims.json` holds: preset, familywise level, design (and its `record` file)
    and every entry."""
    design_dict = {} if design is None else {"design": {**design.to_dict(), "record": record}}
    return {"preset": preset.name, "familywise_level": stats.ALPHA, **design_dict,
            "claims": [e.to_dict() for e in entries]}


def _undecided(entry: dict[str, Any]) -> Verdict:
    """An entry's decision where its test does not pass."""
    v = entry["verdict"]
    return v if v in (Verdict.NOT_RUN, Verdict.TOO_FEW_SEEDS) else Verdict.INCONCLUSIVE


def _fixed(chosen: list[Claim], entries: list[dict[str, Any]], estimates: list, design: Design
           ) -> None:
    """One look: the graph over the claims' p-values, and each size at its Bonferroni share."""
    adjusted = stats.adjusted_verdicts(
        estimates, [c.direction for c in chosen], weights=[design.weights[c.id] for c in chosen],
        tested=[design.family[c.id] != DESCRIPTIVE for c in chosen])
    for claim, entry, est, verdict in zip(chosen, entries, estimates, adjusted, strict=True):
        entry["adjusted_verdict"] = verdict
        _size(claim, entry, design, [] if est is None else [est])


def _size(claim: Claim, entry: dict[str, Any], design: Design, looks: list) -> None:
    """The entry's size: the first look that decides it, else the last (none if descriptive,
    not run, or under the older design)."""
    if design.sizes and design.family[claim.id] != DESCRIPTIVE and looks:
        sizes = [stats.size_decision(e, claim.direction, sizing_effect(entry),
                                     design.level(claim.id), design.sequential, j)
                 for j, e in enumerate(looks)]
        entry["size"] = next((s for s in sizes if s in (Size.SMALLER, Size.LARGER)), sizes[-1])


# --------------------------------------------------------------------------- seeds in stages
def first_seeds(tables: dict[str, TableResult], seeds: int) -> dict[str, TableResult]:
    """The tables as they stood at a look: every entry's first `seeds` training seeds."""
    def cut(entry):
        if entry.data is None:
            return entry
        return replace(entry, data=entry.data[:seeds],
                       motion={m: v[:seeds] for m, v in entry.motion.items()})

    return {t: replace(r, entries={k: cut(c) for k, c in r.entries.items()})
            for t, r in tables.items()}


def _sequential(chosen: list[Claim], entries: list[dict[str, Any]],
                tables: dict[str, TableResult], design: Design, stops: Sequence[str] = ()
                ) -> None:
    """Each entry's `sequential` record, `look`, decision and size under seeds in stages
    (`stats.sequential_graph`); a claim of `stops` was stopped by the run's budget."""
    seq, at_look = design.sequential, {n: first_seeds(tables, n) for n in design.sequential.stages}
    looks, runs, nominal = [], [], []
    for claim, entry in zip(chosen, entries, strict=True):
        seeds = min((entry.get("seeds") or {}).values(), default=0)
        looks.append([] if entry["verdict"] == Verdict.NOT_RUN else [
            claim.compare.estimate(at_look[n]) for n in seq.stages if n <= seeds])
        runs.append(seq.p_values(looks[-1], claim.direction))
        nominal.append([stats.decision_p_value(e, claim.direction) for e in looks[-1]])
    decided, levels = stats.sequential_graph(
        [[r and r[0] for r in run] if design.family[c.id] != DESCRIPTIVE else []
         for c, run in zip(chosen, runs, strict=True)], [design.weights[c.id] for c in chosen])
    last = len(seq.stages) - 1
    for i, (claim, entry) in enumerate(zip(chosen, entries, strict=True)):
        run, nom, k_dec = runs[i], nominal[i], decided[i]
        seeds, k = min((entry.get("seeds") or {}).values(), default=0), len(run) - 1
        level = float(levels[-1, i]) if len(levels) else design.level(claim.id)
        power = [None if nom[j] is None or levels.size == 0 else
                 float(seq.conditional_power(nom[j][0], j, levels[j, i])) for j in range(k + 1)]
        record: dict[str, Any] = {
            "stages": list(seq.stages), "seeds": seeds,
            "looks": [{"seeds": seq.stages[j], "p_value": nom[j] and nom[j][0],
                       "design_p_value": run[j] and run[j][0], "conditional_power": power[j]}
                      for j in range(k + 1)],
            "p_value": run[-1][0] if run and run[-1] else None, "level": level,
            "decided_at": None, "next": None}
        _size(claim, entry, design, looks[i])
        entry["adjusted_verdict"] = _undecided(entry)
        n = seq.stages[k] if k >= 0 else seeds
        if k_dec is not None:
            # a claim whose rows stopped earlier is decided on its last look's data, at a
            # later look of the ledger when the graph passed it the level of claims decided then
            own = min(k_dec, k)
            record["decided_at"] = seq.stages[own]
            entry["adjusted_verdict"] = run[own][1]
            entry["look"] = (f"decided at look {own + 1} of {last + 1} "
                             f"({seq.stages[own]} seeds a row)")
            if k_dec > own:
                entry["look"] += (f", after the graph at the ledger's look {k_dec + 1} "
                                  f"({seq.stages[k_dec]} seeds a row)")
        elif entry["verdict"] == Verdict.NOT_RUN:
            entry["look"] = Verdict.NOT_RUN.value
        elif design.family[claim.id] == DESCRIPTIVE:
            entry["look"] = f"described at {n} seeds, not tested ({design.why[claim.id]})"
        elif k < 0:
            entry["look"] = (f"undecided at {seeds} seeds: before the first look "
                             f"({seq.stages[0]} seeds a row)")
            record["next"] = seq.stages[0]
        elif k == last:
            entry["look"] = f"undecided at {n} seeds, the last look"
        elif claim.id in stops:
            record["stopped_by"] = "budget"
            entry["look"] = (f"undecided at {n} seeds: stopped, {seq.stages[k + 1]} seeds a "
                             "row are over the run's budget")
        elif design.older:
            entry["look"] = f"undecided at {n} seeds, where the older design's run left it"
        elif power[k] is not None and power[k] >= design.continuation_power:
            record["next"] = seq.stages[k + 1]
            entry["look"] = (f"undecided at {n} seeds (conditional power {power[k]:.2f} at "
                             f"its level {level:.2g}): continues to {seq.stages[k + 1]}")
        else:
            cp = "no test" if power[k] is None else f"conditional power {power[k]:.2f}"
            entry["look"] = (f"undecided at {n} seeds: stops ({cp} at its level "
                             f"{level:.2g}, below {design.continuation_power:g})")
        entry["sequential"] = record


def sizing_effect(entry: LedgerEntry | dict[str, Any]) -> float | None:
    """The effect an entry is sized against: `paper`, else `reference_effect` (or None)."""
    e = as_entry(entry)
    return e.paper if e.paper is not None else e.reference_effect


def summary(ledger: Sequence[LedgerEntry | dict[str, Any]], adjusted: bool = True
            ) -> dict[str, Any]:
    """Counts of the ledger's decisions (or verdicts), families and sizes, and how many
    undecided claims 10 seeds a row could decide."""
    entries = [as_entry(e) for e in ledger]
    verdict_of = ((lambda e: e.adjusted_verdict) if adjusted else (lambda e: e.verdict))
    counts = Counter(verdict_of(e) for e in entries)
    undecided = [e for e in entries if verdict_of(e) in verdict_words.UNDECIDED]
    sizes = Counter(e.size for e in entries)
    older = sum(1 for e in entries if e.size is None
                and str(e.extra.get("magnitude") or "").startswith("paper's size excluded"))
    return {
        "claims": len(entries),
        "counts": {v: counts.get(v, 0) for v in VERDICTS},
        "decided": sum(counts.get(v, 0) for v in verdict_words.DECIDED),
        "families": dict(Counter(e.family for e in entries if e.family)),
        "size_excluded": sizes.get(Size.SMALLER, 0) + older,
        "size_larger": sizes.get(Size.LARGER, 0),
        "decidable_with_10_seeds": sum(1 for e in undecided
                                       if e.seeds_needed and e.seeds_needed <= 10),
        "undecided": len(undecided),
    }


def sentence(entry: LedgerEntry | dict[str, Any]) -> str:
    """The verdict of one ledger entry in words, for the chapters."""
    e = as_entry(entry)
    if e.paper is not None:
        against = f"the paper {e.paper:+.3f}"
    elif e.reference_effect is None:
        against = (("a claim of ours" if e.source == "ours" else "the paper")
                   + " with no number to read it against")
    else:
        against = f"a claim of ours, read against {e.reference} ({e.reference_effect:+.3f})"
    if not e.run:
        return f"{e.quantity}: not run yet ({against})."
    low, high = e.ci
    side = "above" if e.direction > 0 else "below"
    seeds = ", ".join(f"{r} {k}" for r, k in (e.seeds or {}).items())
    out = (f"{e.quantity}: {against}, ours {e.ours:+.3f} [{low:+.3f}, {high:+.3f}] "
           f"(seeds: {seeds}); the claim {verdict_words.claim_words(e.verdict, side)}")
    if e.verdict == Verdict.INCONCLUSIVE and "intersection test" in (e.method or ""):
        out += f" ({verdict_words.BEST_OF_K_INCONCLUSIVE})"
    if e.family == DESCRIPTIVE:
        return out + "; descriptive: it decides nothing."
    if e.adjusted_verdict and e.adjusted_verdict != e.verdict:
        where = ("" if not e.family else f" ({e.family})" if e.family.endswith("family")
                 else f" ({e.family} family)")
        out += f"; decided under the ledger's design{where} it is {e.adjusted_verdict}"
    if e.size:
        out += f"; size: {e.size}"
    if e.power is not None:
        out += f"; power {e.power:.0%} to detect the paper's effect at these seeds"
    if e.seeds_needed:
        out += f"; about {e.seeds_needed} seeds a row would detect the paper's effect"
    return out + "."


def read_ledger(path) -> dict[str, Any]:
    """A claims ledger (`claims.json`); UnreadableFileError names a damaged one and the fix."""
    fix = ("regenerate it (`icil-paper reproduce --preset <preset>` writes the ledger) or "
           "restore it from git")
    ledger = read_json(path, "a claims ledger (claims.json)", fix, keys=("claims",))
    claims = ledger["claims"]
    if not isinstance(claims, list) or not all(isinstance(e, dict) and "id" in e
                                               for e in claims):
        raise UnreadableFileError(f"{path} is not a claims ledger (its 'claims' must be a "
                                  f"list of objects with an 'id'); {fix}")
    return ledger


def load_ledger(path) -> list[LedgerEntry]:
    """The entries of a stored `claims.json` (`read_ledger`)."""
    return [LedgerEntry.from_dict(e) for e in read_ledger(path)["claims"]]
