"""The claims engine: a claim of the paper checked against our numbers, and the ledger.

    from icil_paper.paper import claims_ledger, write_ledger
    ledger = claims_ledger(preset, store)          # list of LedgerEntry, one per claim
    write_ledger(preset, store)                   # results/<preset>/claims.json
    summary(ledger)                               # counts of the verdicts after Holm

Each result declares its claims in its own module of `icil_paper.paper` (Table V's in
`paper/table_v.py`, with `diff`, `margin` and `paper_diff` from here), and
`icil_paper.paper.claims` collects them in the ledger's order; this module evaluates them
(`ledger_entries`, `evaluate_claims`) and says them in words (`sentence`,
`summary_sentence`).

Each claim is a quantity with a claimed direction: "LipVQ-VAE beats BC-Transformer by 5.3
points on Table I" is the difference of the two rows' average success, claimed above 0.
Its `paper` value is computed from the paper's own numbers (each beside its table in
`icil_paper.paper`), `ours` from our records, `ci` is our 95% interval with the training
seed as the unit (see `icil_paper.stats`), and each entry carries:

- `verdict`: the rule of `icil_paper.stats` on the interval: `holds`, `does not hold`,
  `inconclusive`, `too few seeds` (a row it reads has one training seed), or `not run` (a
  record it needs is missing);
- `adjusted_verdict`: the verdict after Holm's correction over every testable claim of the
  ledger at a 5% familywise level (the one to quote: 20-odd claims at 95% each would
  otherwise decide about one by chance);
- `magnitude`: our interval against the paper's own size (`stats.magnitude`; success
  differences also say when they lie within +-`EQUIVALENCE_MARGIN` of 0);
- `mde`, `power` and `seeds_needed`: the smallest difference this design detects at 80%
  power, the probability that this design detects the paper's effect, and the seeds per
  row that detect it with 80% power, from the measured per-seed variances
  (a one-seed row borrows the pooled variance of its table's multi-seed rows, else of the
  ledger's; `variance_from` says which);
- `seeds` (row -> training seeds), `n` (all seeds), `episodes`, `method` and `p_value`;
- with seeds in stages (a preset's `tables.seed_stages`, `stats.SequentialDesign`): `look`,
  in words, the look at which the claim was decided ("decided at look 2 of 3 (10 seeds a
  row)") or "undecided at N seeds, needs M" (and whether its rows go on); `sequential`,
  each look's seeds, t-test p-value and the design's running repeated p-value, the
  claim's p-value, `decided_at` (seeds a row), `next` (the stage its rows go on to, else
  None) and `needs` (`stage_seeds_needed`, also the entry's `stage_seeds_needed`); and
  `adjusted_verdict` is then Holm's correction at every look on the design's p-values
  (`stats.sequential_holm`), the one to quote.

Motion smoothness. The paper says in words that LipVQ-VAE gives smoother motion (the
abstract; Sec. IV-B on the real robot) but reports no number for it. Its claims here read
the end-effector paths of the same evaluation episodes (`MotionComparison`: per-episode
LDLJ, the primary quantity, higher is smoother; `icil_paper.metrics`), with the seed as the
unit as for success (`stats.paired_score_difference`, best of k by `smoother_margin`), and
`MotionCorrelation` relates Table III's least energy to Table I's LDLJ across the ICRT
tokenizers. A claim without a number has `paper` and `reference_effect` None: it is
decided like every other claim, but neither sized nor planned (only its `mde`).

The chapters' verdict sentences are generated from these entries (`sentence`).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from icil_paper import stats, verdict_words
from icil_paper.config import Preset
from icil_paper.fileio import UnreadableFileError, read_json
from icil_paper.metrics import MOTION_MEASURES, SMOOTHER
from icil_paper.stats import Verdict
from icil_paper.tables.assemble import TableResult

EQUIVALENCE_MARGIN = 0.05
"""A success difference whose whole interval lies within +-0.05 of 0 (5 points of success,
the size of the gaps the paper reports) is reported as equivalent to 0 at that margin."""

MAX_SEEDS = 1000
"""`seeds_needed` searches up to this many seeds a row."""

VERDICTS = verdict_words.LEDGER_ORDER


@dataclass(frozen=True)
class Comparison:
    """Rows of one table compared on the same episodes (or trajectories): `a` minus the one
    other row, or, with several `others`, `a` against each of them (best of k)."""

    table: str
    a: str
    others: tuple[str, ...]
    column: str = "avg"

    @property
    def kind(self) -> str:
        return "score" if self.column == "least_energy" else "success"

    @property
    def pool(self) -> str:
        """The quantity whose per-seed variances a one-seed row borrows (`_power`)."""
        return "least_energy" if self.kind == "score" else "success"

    @property
    def rows(self) -> tuple[str, ...]:
        return (self.a, *self.others)

    def data(self, tables: dict[str, TableResult]) -> list[np.ndarray] | None:
        data = [tables[self.table].outcomes(label, self.column) for label in self.rows]
        return None if any(d is None for d in data) else data

    def estimate(self, tables: dict[str, TableResult]) -> stats.Estimate | None:
        data = self.data(tables)
        if data is None:
            return None
        if self.kind == "score":
            if len(self.others) == 1:
                return stats.paired_score_difference(*data)
            return stats.paired_score_margin(data[0], data[1:])
        scenes = tables[self.table].scenes(*self.rows, column=self.column)
        if len(self.others) == 1:
            return stats.paired_difference(*data, scenes=scenes)
        return stats.paired_margin(data[0], data[1:], scenes=scenes)


@dataclass(frozen=True)
class Correlation:
    """Spearman correlation across `rows` of Table III's least energy and Table I's success."""

    rows: tuple[str, ...]
    table: str = "III"
    kind: str = "correlation"

    def data(self, tables: dict[str, TableResult]):
        smooth = [tables["III"].outcomes(r, "least_energy") for r in self.rows]
        success = [tables["I"].outcomes(r, "avg") for r in self.rows]
        return None if any(x is None for x in smooth + success) else (smooth, success)

    def estimate(self, tables: dict[str, TableResult]) -> stats.Estimate | None:
        data = self.data(tables)
        return None if data is None else stats.score_success_correlation(*data)


@dataclass(frozen=True)
class MotionComparison:
    """Rows of one table compared on the motion smoothness of the same episodes
    (`metrics.MOTION_MEASURES`; per-episode values, the seed as the unit, as for success):
    `a` minus the one other row, or, with several `others`, `a` against each of them (best
    of k: a's mean minus the smoothest other row's, `smoother_margin`)."""

    table: str
    a: str
    others: tuple[str, ...]
    measure: str = "ldlj"
    column: str = "avg"
    kind: str = "score"

    @property
    def pool(self) -> str:
        return self.measure

    @property
    def rows(self) -> tuple[str, ...]:
        return (self.a, *self.others)

    def data(self, tables: dict[str, TableResult]) -> list[np.ndarray] | None:
        data = [tables[self.table].motion_scores(label, self.column, self.measure)
                for label in self.rows]
        return None if any(d is None for d in data) else data

    def estimate(self, tables: dict[str, TableResult]) -> stats.Estimate | None:
        data = self.data(tables)
        if data is None:
            return None
        if len(self.others) == 1:
            return stats.paired_score_difference(*data)
        return smoother_margin(data[0], data[1:], SMOOTHER[self.measure])


def smoother_margin(a: np.ndarray, others: Sequence[np.ndarray], smoother: int) -> stats.Estimate:
    """Row `a`'s mean score minus that of the smoothest of `others` (`smoother` +1: the
    highest, as for LDLJ and SPARC; -1: the lowest), all on the same episodes. Its
    components are `stats.paired_score_difference(a, other)` for each other row, and
    `stats.verdict` applies the intersection-union test to them, as for every best-of-k
    claim (`stats.paired_score_margin` is this margin for -1)."""
    if smoother == -1:
        return stats.paired_score_margin(a, others)
    pairwise = [stats.paired_score_difference(a, o, rng_seed=i) for i, o in enumerate(others)]
    means = [float(np.mean(o)) for o in others]
    best = int(np.argmax(means))
    value = float(np.mean(a)) - means[best]
    closest = pairwise[best]
    seeds = (pairwise[0].seeds[0], *(c.seeds[1] for c in pairwise))
    return stats.Estimate(
        value, min(closest.low, value), max(closest.high, value), n=sum(seeds),
        method=f"margin over the highest other row: intersection test over {len(pairwise)} "
               f"rows ({closest.method} to the highest other row)",
        seeds=seeds, episodes=int(np.size(a) + sum(np.size(o) for o in others)),
        components=tuple(pairwise))


@dataclass(frozen=True)
class MotionCorrelation:
    """Spearman correlation across `rows` of Table III's least energy (the latents'
    smoothness) and the motion smoothness of Table I's rollouts (`measure`, average over
    the kitchen tasks), with a joint bootstrap: each resample draws every row's training
    seeds with replacement (the same seeds for both of its quantities), then the held-out
    trajectories and the evaluation episodes (the same indices for every row), and
    `stats.rank_correlation_interval` takes the percentiles."""

    rows: tuple[str, ...]
    measure: str = "ldlj"
    table: str = "III"
    kind: str = "correlation"
    n_boot: int = 2000

    def data(self, tables: dict[str, TableResult]):
        smooth = [tables["III"].outcomes(r, "least_energy") for r in self.rows]
        motion = [tables["I"].motion_scores(r, "avg", self.measure) for r in self.rows]
        return None if any(x is None for x in smooth + motion) else (smooth, motion)

    def estimate(self, tables: dict[str, TableResult]) -> stats.Estimate | None:
        data = self.data(tables)
        if data is None:
            return None
        smooth, motion = ([np.atleast_2d(np.asarray(x, np.float64)) for x in xs] for xs in data)
        rng = np.random.default_rng(0)
        traj_idx = rng.integers(0, smooth[0].shape[1], size=(self.n_boot, smooth[0].shape[1]))
        ep_idx = rng.integers(0, motion[0].shape[1], size=(self.n_boot, motion[0].shape[1]))
        x = [stats.mean_samples(e, n_boot=self.n_boot, rng_seed=i + 1, idx=traj_idx)
             for i, e in enumerate(smooth)]
        y = [stats.mean_samples(m, n_boot=self.n_boot, rng_seed=i + 1, idx=ep_idx)
             for i, m in enumerate(motion)]
        seeds = tuple(min(len(e), len(m)) for e, m in zip(smooth, motion, strict=True))
        return stats.rank_correlation_interval(
            np.stack(x), np.stack(y), x=np.array([e.mean() for e in smooth]),
            y=np.array([m.mean() for m in motion]), seeds=seeds)


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
    """The same quantity from the paper's numbers; for a claim of our own (`own`), the
    effect it is read and planned against (`reference_effect` in the ledger). None where
    there is no number: a claim the paper makes in words only (its entry's `paper` and
    `reference_effect` are None, `reference` says why; nothing is planned)."""
    own: bool = False
    """A claim of this companion, not of the paper (the `beyond` table's): its entry has
    no `paper` value, only `reference_effect`, named in `reference`."""
    reference: str = ""
    """What the reference effect of an own claim is."""


@dataclass
class LedgerEntry:
    """One claim of the ledger as `ledger_entries` computes it and `claims.json` stores it
    (`to_dict` gives the stored form, key for key; `from_dict` reads it back). Fields a
    newer ledger adds are kept in `extra` and read as attributes too."""

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
    paper: float | None = None
    """The same quantity from the paper's numbers (None for a claim of ours or in words)."""
    reference_effect: float | None = None
    """For a claim with no `paper` value: the effect it is sized against, if any."""
    reference: str | None = None
    """What `reference_effect` is (stored only for a claim with no `paper` value)."""
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
    magnitude: str | None = None
    mde: float | None = None
    power: float | None = None
    seeds_needed: int | None = None
    variance_from: dict[str, str] | None = None
    power_note: str | None = None
    adjusted_verdict: Verdict | str | None = None
    """The verdict after Holm's correction over the ledger (the one to quote)."""
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
        for key in ("verdict", "adjusted_verdict"):
            if known.get(key) in _VERDICT_VALUES:
                known[key] = Verdict(known[key])
        return cls(**known, extra={k: v for k, v in data.items() if k not in names},
                   order=tuple(data))

    def to_dict(self) -> dict[str, Any]:
        order = self.order or tuple(self._stored_fields()) + tuple(self.extra)
        return {k: (self.extra[k] if k in self.extra else getattr(self, k)) for k in order}

    def _stored_fields(self):
        for f in fields(self):
            if f.name in ("extra", "order"):
                continue
            if f.name in ("reference_effect", "reference") and not (
                    self.source == "ours" or self.paper is None):
                continue
            if f.name == "adjusted_verdict" and self.adjusted_verdict is None:
                continue
            yield f.name


_VERDICT_VALUES = {v.value for v in Verdict}


def as_entry(entry: LedgerEntry | dict[str, Any]) -> LedgerEntry:
    """A ledger entry as a `LedgerEntry` (a stored one, a dict, is read with `from_dict`)."""
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


# --------------------------------------------------------------------------- the ledger
def _pooled_variances(tables: dict[str, TableResult]) -> dict[tuple[str, str], float]:
    """(table, quantity) -> the mean per-seed variance of its multi-seed rows (`success`:
    the "avg" column; `least_energy`; each motion measure of the "avg" column), and
    ("*", quantity) over every table: what a one-seed row borrows for the power analysis."""
    pooled: dict[tuple[str, str], list[float]] = {}

    def add(table_id: str, quantity: str, data, kind: str) -> None:
        var = stats.seed_variance(data, kind)
        if var is not None:
            pooled.setdefault((table_id, quantity), []).append(var)
            pooled.setdefault(("*", quantity), []).append(var)

    for table_id, result in tables.items():
        for (row, column), cell in result.cells.items():
            if cell.data is None or column not in ("avg", "least_energy"):
                continue
            if column == "least_energy":
                add(table_id, "least_energy", cell.data, "score")
                continue
            add(table_id, "success", cell.data, "success")
            for measure in MOTION_MEASURES:
                scores = result.motion_scores(row, column, measure)
                if scores is not None:
                    add(table_id, measure, scores, "score")
    return {k: float(np.mean(v)) for k, v in pooled.items()}


def _power(claim: Claim, estimate: stats.Estimate, tables: dict[str, TableResult],
           pooled: dict[tuple[str, str], float], paper_value: float | None,
           design: stats.SequentialDesign | None = None) -> dict[str, Any]:
    """mde, seeds_needed and where each row's seed variance came from (see the module
    docstring). Best of k: planned against the closest other row (smallest pairwise margin
    on the claimed side), the comparison that decides the intersection test."""
    out: dict[str, Any] = {"mde": None, "power": None, "seeds_needed": None,
                           "variance_from": None, "power_note": None}
    compare = claim.compare
    if not isinstance(compare, (Comparison, MotionComparison)):
        out["power_note"] = "not planned: a rank correlation across rows has no closed form"
        return out
    data = dict(zip(compare.rows, compare.data(tables), strict=True))
    other = compare.others[0]
    if estimate.components:
        j = int(np.argmin([claim.direction * c.value for c in estimate.components]))
        other = compare.others[j]
    variances, source, seeds = [], {}, []
    for label in (compare.a, other):
        var = stats.seed_variance(data[label], compare.kind)
        seeds.append(len(data[label]))
        if var is not None:
            source[label] = "own seeds"
        elif (compare.table, compare.pool) in pooled:
            var, source[label] = pooled[(compare.table, compare.pool)], \
                f"pooled over Table {compare.table}'s multi-seed rows"
        elif ("*", compare.pool) in pooled:
            var, source[label] = pooled[("*", compare.pool)], "pooled over the ledger's rows"
        else:
            return {**out, "power_note": "no row with two seeds to measure a variance"}
        variances.append(var)
    out["variance_from"] = source
    if min(seeds) >= 2:
        out["mde"] = stats.minimum_detectable(*variances, *seeds)
    if paper_value is None:
        out["power_note"] = "no reference effect (no number to plan for): only the mde"
    elif claim.direction * paper_value > 0:
        if min(seeds) >= 2:
            out["power"] = stats.power_at(*variances, *seeds, paper_value)
        out["seeds_needed"] = stats.seeds_needed(*variances, paper_value, max_seeds=MAX_SEEDS)
        if design is not None:
            needed = stats.stage_seeds_needed(*variances, paper_value, design,
                                              max_seeds=MAX_SEEDS)
            out["stage_seeds_needed"] = None if np.isnan(needed) else int(needed)
        if out["seeds_needed"] is None:
            out["power_note"] = (f"the paper's effect ({paper_value:+.3g}) would need more than "
                                 f"{MAX_SEEDS} seeds a row")
    else:
        out["power_note"] = "the paper's own value is not on the claimed side: nothing to plan"
    return out


def _evaluate(claim: Claim, tables: dict[str, TableResult],
              pooled: dict[tuple[str, str], float],
              design: stats.SequentialDesign | None = None) -> tuple[dict[str, Any], Any]:
    """One ledger entry (the claim, the paper's number, ours with its interval, the verdict,
    the size reading and the power) and its estimate (None when not run), from which the
    ledger adds the Holm-adjusted verdict."""
    estimate = claim.compare.estimate(tables)
    paper_value = (None if claim.paper_value is None
                   else round(float(claim.paper_value()), 4))
    entry: dict[str, Any] = {"id": claim.id, "claim": claim.claim, "table": claim.table,
                             "quantity": claim.quantity, "direction": claim.direction,
                             "source": "ours" if claim.own else "the paper",
                             "paper": None if claim.own else paper_value}
    if claim.own or paper_value is None:
        entry.update(reference_effect=paper_value, reference=claim.reference)
    if estimate is None:
        entry.update(ours=None, ci=None, n=None, episodes=None, seeds=None, method=None,
                     p_value=None, verdict=Verdict.NOT_RUN, magnitude=None, mde=None, power=None,
                     seeds_needed=None, variance_from=None, power_note=None)
        return entry, None
    test = stats.decision_p_value(estimate, claim.direction)
    margin_ = EQUIVALENCE_MARGIN if claim.compare.kind == "success" else None
    entry.update(ours=estimate.value, ci=[estimate.low, estimate.high], n=estimate.n,
                 episodes=estimate.episodes,
                 seeds=dict(zip(claim.compare.rows, estimate.seeds, strict=True)),
                 method=estimate.method, p_value=None if test is None else test[0],
                 verdict=stats.verdict(estimate, direction=claim.direction),
                 magnitude=(None if paper_value is None else
                            stats.magnitude(estimate, claim.direction, paper_value, margin_)),
                 **_power(claim, estimate, tables, pooled, paper_value, design))
    return entry, estimate


def ledger_entries(preset: Preset, chosen: Sequence[Claim], tables: dict[str, TableResult]
                   ) -> list[LedgerEntry]:
    """`chosen` claims evaluated on the assembled `tables` they read (every claim's table and
    Table I, which the correlations read), with the verdicts after Holm's correction over
    `chosen` (`adjusted_verdict`) and, with the preset's seed stages, the group-sequential
    ones (`icil_paper.paper.claims_ledger` gives it every claim of the paper)."""
    pooled = _pooled_variances(tables)
    design = stage_design(preset)
    entries, estimates = zip(*(_evaluate(c, tables, pooled, design) for c in chosen),
                             strict=True)
    adjusted = stats.adjusted_verdicts(estimates, [c.direction for c in chosen])
    for entry, verdict in zip(entries, adjusted, strict=True):
        entry["adjusted_verdict"] = verdict
    if design is not None:
        _sequential(list(chosen), list(entries), tables, design, preset.tables.stage_stops)
    return [LedgerEntry.from_dict(e) for e in entries]


def ledger_file(preset: Preset, entries: Sequence[LedgerEntry]) -> dict[str, Any]:
    """What `claims.json` holds: the preset, the familywise level, the equivalence margin
    and every entry in its stored form."""
    return {"preset": preset.name, "familywise_level": stats.ALPHA,
            "equivalence_margin": EQUIVALENCE_MARGIN, "claims": [e.to_dict() for e in entries]}


# --------------------------------------------------------------------------- seeds in stages
def stage_design(preset: Preset) -> stats.SequentialDesign | None:
    """The preset's group-sequential design (`TablesConfig.seed_stages`), None for a fixed
    design."""
    stages = preset.tables.seed_stages
    return stats.SequentialDesign(tuple(stages)) if stages else None


def first_seeds(tables: dict[str, TableResult], seeds: int) -> dict[str, TableResult]:
    """The tables as they stood at a look: every cell's first `seeds` training seeds."""
    def cut(cell):
        if cell.data is None:
            return cell
        return replace(cell, data=cell.data[:seeds],
                       motion={m: v[:seeds] for m, v in cell.motion.items()})

    return {t: replace(r, cells={k: cut(c) for k, c in r.cells.items()})
            for t, r in tables.items()}


def _sequential(all_claims: list[Claim], entries: list[dict[str, Any]],
                tables: dict[str, TableResult], design: stats.SequentialDesign,
                stops: Sequence[str] = ()) -> None:
    """Add each entry's `sequential` record and `look`, and replace `adjusted_verdict` by
    the group-sequential Holm verdict (`stats.sequential_holm` on the repeated p-values
    of every look the claim's rows have reached; module docstring of `icil_paper.stats`).
    A claim of `stops` (`TablesConfig.stage_stops`) was stopped by the run's budget: it
    does not go on, and its `look` says so."""
    at_look = {n: first_seeds(tables, n) for n in design.stages}
    runs: list[list] = []
    nominal: list[list] = []
    for claim, entry in zip(all_claims, entries, strict=True):
        seeds = min((entry.get("seeds") or {}).values(), default=0)
        looks = [] if entry["verdict"] == Verdict.NOT_RUN else [
            claim.compare.estimate(at_look[n]) for n in design.stages if n <= seeds]
        runs.append(stats.sequential_p_value(looks, claim.direction, design))
        nominal.append([stats.decision_p_value(e, claim.direction) for e in looks])
    decided = stats.sequential_holm([[None if t is None else t[0] for t in r] for r in runs])
    last = len(design.stages) - 1
    for entry, run, nom, k_dec in zip(entries, runs, nominal, decided, strict=True):
        seeds = min((entry.get("seeds") or {}).values(), default=0)
        k = len(run) - 1  # the last look reached (-1: none)
        record: dict[str, Any] = {
            "stages": list(design.stages), "seeds": seeds,
            "looks": [{"seeds": design.stages[j],
                       "p_value": None if nom[j] is None else nom[j][0],
                       "design_p_value": None if run[j] is None else run[j][0]}
                      for j in range(len(run))],
            "p_value": run[-1][0] if run and run[-1] else None,
            "decided_at": None, "next": None, "needs": entry.get("stage_seeds_needed")}
        if k_dec is not None:
            # a claim whose rows stopped earlier is decided on its last look's data, at a
            # later look of the ledger when Holm passed it the alpha of claims decided there
            own = min(k_dec, k)
            record["decided_at"] = design.stages[own]
            entry["adjusted_verdict"] = run[own][1]
            entry["look"] = (f"decided at look {own + 1} of {last + 1} "
                             f"({design.stages[own]} seeds a row)")
            if k_dec > own:
                entry["look"] += (f", after Holm's correction at the ledger's look {k_dec + 1} "
                                  f"({design.stages[k_dec]} seeds a row)")
        elif entry["verdict"] == Verdict.NOT_RUN:
            entry["look"] = Verdict.NOT_RUN.value
        else:
            if entry["adjusted_verdict"] in (Verdict.HOLDS, Verdict.DOES_NOT_HOLD):
                entry["adjusted_verdict"] = Verdict.INCONCLUSIVE  # not at a look's boundary
            needs = record["needs"]
            if k < 0:
                entry["look"] = (f"undecided at {seeds} seeds: before the first look "
                                 f"({design.stages[0]} seeds a row)")
                record["next"] = design.stages[0]
            elif k < last and needs is not None and needs <= design.stages[-1]:
                planned = (f"needs {needs}" if needs > design.stages[k] else
                           f"80% power at the paper's effect from {needs}")
                if entry["id"] in stops:
                    record["stopped_by"] = "budget"
                    entry["look"] = (f"undecided at {design.stages[k]} seeds ({planned}): "
                                     f"stopped, {design.stages[k + 1]} seeds a row are "
                                     "over the run's budget")
                else:
                    record["next"] = design.stages[k + 1]
                    entry["look"] = (f"undecided at {design.stages[k]} seeds ({planned}): "
                                     f"continues to {design.stages[k + 1]}")
            elif needs is not None:
                entry["look"] = f"undecided at {design.stages[k]} seeds, needs {needs}"
            else:
                entry["look"] = (f"undecided at {design.stages[k]} seeds, "
                                 f"{entry.get('power_note') or 'needs more than ' + str(MAX_SEEDS)}")
        entry["sequential"] = record


def sizing_effect(entry: LedgerEntry | dict[str, Any]) -> float | None:
    """The effect a ledger entry is sized against: the paper's value, or for a claim of our
    own (no `paper` value) its `reference_effect`; None where the claim has no number."""
    e = as_entry(entry)
    return e.paper if e.paper is not None else e.reference_effect


def summary(ledger: Sequence[LedgerEntry | dict[str, Any]], adjusted: bool = True
            ) -> dict[str, Any]:
    """What a reader asks first: how many claims hold, do not hold, exclude the paper's
    size, or remain undecided (after Holm's correction by default), and which undecided
    claims this design could decide with more seeds."""
    entries = [as_entry(e) for e in ledger]
    verdict_of = ((lambda e: e.adjusted_verdict) if adjusted else (lambda e: e.verdict))
    counts = Counter(verdict_of(e) for e in entries)
    undecided = [e for e in entries if verdict_of(e) in verdict_words.UNDECIDED]
    return {
        "claims": len(entries),
        "counts": {v: counts.get(v, 0) for v in VERDICTS},
        "decided": sum(counts.get(v, 0) for v in verdict_words.DECIDED),
        "size_excluded": sum(1 for e in entries
                             if (e.magnitude or "").startswith("paper's size excluded")),
        "within_margin": sum(1 for e in entries if "within ±" in (e.magnitude or "")),
        "decidable_with_10_seeds": sum(1 for e in undecided
                                       if e.seeds_needed and e.seeds_needed <= 10),
        "undecided": len(undecided),
    }


def summary_sentence(ledger: Sequence[LedgerEntry | dict[str, Any]]) -> str:
    """`summary` in one sentence, for the introduction and chapter 0."""
    s = summary(ledger)
    c = s["counts"]
    if c[Verdict.NOT_RUN] == s["claims"]:
        return f"None of the {s['claims']} claims has its records yet: every one is not run."
    parts = [verdict_words.counted(v, c[v]) for v in VERDICTS if v != Verdict.NOT_RUN]
    if c[Verdict.NOT_RUN]:
        parts.append(verdict_words.counted(Verdict.NOT_RUN, c[Verdict.NOT_RUN]))

    def claims_(k: int, one: str, many: str) -> str:
        return f"{k} {one if k == 1 else many}"

    return (f"Of {s['claims']} claims, after Holm's correction: " + ", ".join(parts) + ". "
            f"{claims_(s['size_excluded'], 'excludes', 'exclude')} the paper's size of the "
            f"effect, {claims_(s['within_margin'], 'lies', 'lie')} within "
            f"±{EQUIVALENCE_MARGIN:g} of 0, and {s['decidable_with_10_seeds']} of the "
            f"{s['undecided']} undecided would detect the paper's effect with 10 or fewer "
            "seeds a row.")


def paper_words(entry: LedgerEntry) -> str:
    """What a ledger entry is read against, in words: "the paper +0.053", "a claim of ours,
    read against <reference> (+0.055)", or "... with no number to read it against"."""
    if entry.paper is not None:
        return f"the paper {entry.paper:+.3f}"
    if entry.reference_effect is None:
        return (("a claim of ours" if entry.source == "ours" else "the paper")
                + " with no number to read it against")
    return f"a claim of ours, read against {entry.reference} ({entry.reference_effect:+.3f})"


def sentence(entry: LedgerEntry | dict[str, Any]) -> str:
    """The verdict of one ledger entry in words, for the chapters."""
    e = as_entry(entry)
    against = paper_words(e)
    if not e.run:
        return f"{e.quantity}: not run yet ({against})."
    low, high = e.ci
    side = "above" if e.direction > 0 else "below"
    seeds = ", ".join(f"{r} {k}" for r, k in (e.seeds or {}).items())
    out = (f"{e.quantity}: {against}, ours {e.ours:+.3f} [{low:+.3f}, {high:+.3f}] "
           f"(seeds: {seeds}); the claim {verdict_words.claim_words(e.verdict, side)}")
    if e.verdict == Verdict.INCONCLUSIVE and "intersection test" in (e.method or ""):
        out += f" ({verdict_words.BEST_OF_K_INCONCLUSIVE})"
    if e.adjusted_verdict and e.adjusted_verdict != e.verdict:
        out += f"; after Holm's correction over the ledger it is {e.adjusted_verdict}"
    if e.magnitude and e.magnitude != Verdict.TOO_FEW_SEEDS:
        out += f"; {e.magnitude}"
    if e.seeds_needed:
        out += f"; about {e.seeds_needed} seeds a row would detect the paper's effect"
    return out + "."


def read_ledger(path) -> dict[str, Any]:
    """A claims ledger (`claims.json`), through `fileio.read_json`: a damaged one, or one
    whose `claims` are not objects with an `id`, is one line naming it and the fix."""
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


def evaluate_claims(chosen: Sequence[Claim], tables: dict[str, TableResult]
                    ) -> list[dict[str, Any]]:
    """Ledger entries of `chosen` claims on assembled `tables` (as `ledger_entries` makes
    them: the verdict, the size reading and the power, each row's variance pooled over
    `tables` where it has one seed), Holm-adjusted over `chosen` (`icil-paper compare`)."""
    pooled = _pooled_variances(tables)
    entries, estimates = zip(*(_evaluate(c, tables, pooled) for c in chosen), strict=True)
    adjusted = stats.adjusted_verdicts(estimates, [c.direction for c in chosen])
    for entry, verdict in zip(entries, adjusted, strict=True):
        entry["adjusted_verdict"] = verdict
    return list(entries)
