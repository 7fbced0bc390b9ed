"""The paper's tables: specs share cells where the paper's tables share policies, records
become numbers with intervals, claims get verdicts from those intervals, and committed
reference records match the current code's keys."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from icil_paper.config import get_preset
from icil_paper.config_data import spec_key
from icil_paper.paper import TABLES, claims, claims_ledger, table_spec, write_ledger
from icil_paper.results import ResultsStore
from icil_paper.runspec import eval_key
from icil_paper.tables.assemble import assemble
from icil_paper.tables.cells import plan
from icil_paper.tables.claims import as_entry
from record_helpers import write_eval_record

ROOT = Path(__file__).resolve().parents[1]


def small_preset(*overrides):
    return get_preset("smoke").with_overrides(
        ["data.robocasa_tasks=kitchen/open_drawer,kitchen/close_drawer,kitchen/open_door",
         *overrides])


def run_keys(spec, label):
    return {u.run.key() for u in spec.row(label).entries["avg"].units}


@pytest.mark.parametrize("preset_name", ["smoke", "small", "reference"])
def test_every_table_builds_and_every_row_is_evaluated_on_the_same_episodes(preset_name):
    preset = get_preset(preset_name)
    for table_id in TABLES:
        spec = table_spec(preset, table_id)
        assert spec.rows and spec.columns
        # every row's seed k plays the same scenes: the preset's, or scene set k
        seeds = {(u.seed_index, u.eval.seed) for u in spec.units() if u.eval is not None}
        scene_of = ((lambda k: preset.seed + k) if preset.tables.scenes_per_seed
                    else (lambda k: preset.seed))
        assert all(seed == scene_of(k) for k, seed in seeds), f"table {table_id}: rows are not paired"
        for row in spec.rows:
            assert set(row.entries) <= set(spec.columns) | set(spec.beside), (table_id, row.label)


def test_tables_share_the_policies_the_paper_shares():
    preset = get_preset("reference")
    t1, t4, t6, f5 = (table_spec(preset, t) for t in ("I", "IV", "VI", "fig5"))
    for label in ("icrt+mlp", "icrt+vq", "icrt+lipvq"):
        assert run_keys(t4, label) == run_keys(t1, label), label
        assert len(run_keys(t1, label)) == preset.tables.icrt_seeds
    assert len(run_keys(t1, "act")) == preset.tables.baseline_seeds
    # Table VI evaluates Table I's policies on the human-like scenes (ICRT with human-like
    # prompts): the same runs, no evaluation of Table I's
    t1_evals = {eval_key(u.run, u.eval) for u in t1.units()}
    t6_bc = {eval_key(u.run, u.eval) for u in t6.row("bc_transformer").entries["avg"].units}
    t6_icrt = {eval_key(u.run, u.eval) for u in t6.row("icrt+mlp").entries["avg"].units}
    assert not t6_bc & t1_evals and not t6_icrt & t1_evals
    assert run_keys(t6, "bc_transformer") == run_keys(t1, "bc_transformer")
    # Fig. 5 reuses Table I's LipVQ-VAE run at the preset's codebook size (seed 0)
    size = preset.tokenizers.lipvq.codebook_size
    row = next(r for r in f5.rows if r.label.split()[0] == f"2^{size.bit_length() - 1}")
    assert run_keys(f5, row.label) <= run_keys(t1, "icrt+lipvq")
    plans = plan([table_spec(preset, t) for t in TABLES])
    assert len(plans) == len({p.run.key() for p in plans})  # one plan per trained policy


@pytest.mark.parametrize("preset_name", ["smoke", "small", "reference"])
def test_chapter_02s_run_is_the_icrt_table_with_the_keys_it_always_had(preset_name):
    """`TABLES["icrt"]` is one cell of one unit: ICRT + LipVQ-VAE trained on the task alone
    and evaluated there as the preset says, so its records keep the names and keys chapter
    02's run had before it was a table; it shares no policy with another table."""
    from icil_paper.paper.icrt_demo import ICRT_DEMO_TASK, icrt_records, icrt_specs
    from icil_paper.records import eval_record, train_record
    from icil_paper.runspec import eval_spec, run_spec

    preset = get_preset(preset_name)
    spec = TABLES["icrt"](preset)
    [unit] = spec.units()
    run = run_spec(preset, "icrt", "lipvq", tasks=[ICRT_DEMO_TASK])
    ev = eval_spec(preset, ICRT_DEMO_TASK)
    assert (unit.seed_index, unit.run.key(), eval_key(unit.run, unit.eval)) == (
        0, run.key(), eval_key(run, ev))
    assert train_record(unit.run) == train_record(run)
    assert eval_record(unit.run, unit.eval) == eval_record(run, ev)
    assert icrt_specs(preset) == (unit.run, unit.eval)
    assert [r.label for r in spec.rows] == ["icrt+lipvq"] and len(spec.columns) == 1
    others = {u.run.key() for t in TABLES if t != "icrt" for u in table_spec(preset, t).units()}
    assert run.key() not in others
    assert icrt_records(preset, ResultsStore(preset_name, root=ROOT / "no-such-folder")) is None


def test_zero_shot_trains_on_ml45_and_no_held_out_task_reaches_training():
    from icil_paper.data.splits import zero_shot_split

    train, held = zero_shot_split()
    assert len(train) == 45 and len(held) == 5
    spec = table_spec(get_preset("small"), "VII")
    assert spec.units()
    for unit in spec.units():
        assert set(unit.run.data.tasks) == set(train)
        assert not set(unit.run.data.tasks) & set(held)  # no held-out task's data in training
        assert unit.eval.task in held
        if unit.eval.prompt_task is not None:  # ICRT's prompt: a demonstration of the unseen task
            assert unit.eval.prompt_task == unit.eval.task
    cells = spec.row("icrt+lipvq").entries
    assert cells.keys() >= {"pick_place", "doors", "knobs", "insertion", "avg"}
    assert not cells.keys() & {"drawers", "levers", "buttons"}  # no held-out task: n/a


def test_a_held_out_task_in_zero_shot_training_is_refused():
    with pytest.raises(ValueError, match="metaworld/door-lock, held out for the zero-shot"):
        get_preset("small").with_overrides(
            ["data.zero_shot_tasks=metaworld/reach,metaworld/door-lock"])


def test_prompt_ablation_uses_another_task_and_a_cut_prompt():
    spec = table_spec(get_preset("small"), "prompt")
    wrong = spec.row("another task's prompt").entries["avg"].units
    assert all(u.eval.prompt_task and u.eval.prompt_task != u.eval.task for u in wrong)
    pairs = {u.eval.task: u.eval.prompt_task for u in wrong}
    assert pairs["metaworld/drawer-open"] == "metaworld/drawer-close"
    assert pairs["metaworld/faucet-close"] == "metaworld/faucet-open"
    assert pairs["metaworld/dial-turn"] != "metaworld/dial-turn"  # no opposite: the next task
    cut = spec.rows[2].entries["avg"].units
    assert all(u.eval.prompt_steps == get_preset("small").tables.prompt_steps for u in cut)


def fake_records(preset, store, table_id, rate_of, episodes=None, seed=0):
    """Write an eval record for every unit of a table: success drawn with rate_of(row)."""
    spec = table_spec(preset, table_id)
    rng = np.random.default_rng(seed)
    for row in spec.rows:
        for entry in row.entries.values():
            for unit in entry.units:
                if unit.eval is None:
                    continue
                n = episodes or unit.eval.episodes
                per = [{"episode": i, "success": bool(rng.random() < rate_of(row.label)),
                        "steps": 5} for i in range(n)]
                write_eval_record(store, unit, per, mean_steps=5.0)


def test_records_become_estimates_and_claims_get_their_verdicts():
    preset = small_preset("eval.episodes_per_task=40", "tables.icrt_seeds=3",
                          "tables.baseline_seeds=3")
    store = ResultsStore(preset.name)
    strong = {"icrt+lipvq": 0.9, "bc_transformer": 0.02}
    fake_records(preset, store, "I", lambda row: strong.get(row, 0.5))
    result = assemble(table_spec(preset, "I"), store)
    shown = [c for (_, column), c in result.entries.items() if column in result.spec.columns]
    assert all(c.estimate is not None for c in shown)  # (the codebook features beside: not run)
    est = result.estimate("icrt+lipvq", "avg")
    assert 0.8 < est.value < 1.0 and est.low < est.value < est.high
    assert result.outcomes("icrt+lipvq", "avg").shape == (3, 3, 40)  # seeds, tasks, episodes
    assert result.entry("icrt+lipvq", "pick_place") is None  # no such task in this preset
    ledger = {e.id: e for e in claims_ledger(preset, store)}
    assert ledger["I-lipvq-vs-bc"].verdict == "holds"
    assert ledger["I-lipvq-vs-bc"].adjusted_verdict == "holds"
    assert ledger["I-lipvq-vs-bc"].seeds == {"icrt+lipvq": 3, "bc_transformer": 3}
    assert ledger["I-lipvq-vs-bc"].n == 6 and ledger["I-lipvq-vs-bc"].episodes == 720
    assert ledger["I-lipvq-vs-bc"].mde > 0 and ledger["I-lipvq-vs-bc"].seeds_needed >= 2
    assert ledger["I-lipvq-best"].verdict == "holds"
    assert ledger["I-mlp-below-bc"].verdict == "does not hold"  # BC 0.02 is below MLP 0.5
    # sizes at each claim's Bonferroni share: a primary claim's (0.05 * 0.8 / 6) decides at
    # three seeds that +0.88 is larger than the paper's +0.053; a secondary claim's (0.05 *
    # 0.2 / 16) leaves the size of -0.48 against the paper's +0.035 undecided
    assert ledger["I-lipvq-vs-bc"].family == "primary"
    assert ledger["I-lipvq-vs-bc"].size == "larger than the paper's effect"
    assert ledger["I-mlp-below-bc"].family == "secondary"
    assert ledger["I-mlp-below-bc"].size == "size undecided"
    assert ledger["III-smoother-succeeds"].family == "descriptive"
    assert ledger["II-lipvq-best"].verdict == "not run"
    assert ledger["I-lipvq-vs-bc"].paper == pytest.approx(0.530 - 0.477, abs=1e-4)
    lo, hi = ledger["I-lipvq-vs-bc"].ci
    assert lo <= ledger["I-lipvq-vs-bc"].ours <= hi


def test_equal_rows_are_inconclusive_and_reversed_ones_do_not_hold():
    preset = small_preset("eval.episodes_per_task=30", "tables.icrt_seeds=3")
    store = ResultsStore(preset.name)
    fake_records(preset, store, "IV", lambda row: 0.9 if row == "icrt+vq" else 0.5)
    ledger = {e.id: e for e in claims_ledger(preset, store)}
    assert ledger["IV-vq"].verdict == "does not hold"  # LipVQ 0.5 vs VQ 0.9
    assert ledger["IV-mlp"].verdict == "inconclusive"  # both 0.5


def test_one_seed_rows_are_never_decided():
    preset = small_preset("eval.episodes_per_task=40")  # one seed a row
    store = ResultsStore(preset.name)
    fake_records(preset, store, "I",
                 lambda row: {"icrt+lipvq": 0.95, "bc_transformer": 0.02}.get(row, 0.5))
    ledger = {e.id: e for e in claims_ledger(preset, store)}
    entry = ledger["I-lipvq-vs-bc"]
    assert entry.ci[0] > 0.5  # the episodes alone would say so, ...
    assert entry.verdict == entry.adjusted_verdict == "too few seeds"  # ... seeds cannot
    assert entry.seeds == {"icrt+lipvq": 1, "bc_transformer": 1} and entry.mde is None


def test_missing_records_show_as_not_run_and_the_ledger_is_written(tmp_path):
    preset = small_preset()
    store = ResultsStore(preset.name)
    result = assemble(table_spec(preset, "I"), store)
    assert not result.complete and result.estimate("icrt+lipvq") is None
    path = write_ledger(preset, store)
    entries = json.loads(Path(path).read_text())["claims"]
    assert {e["verdict"] for e in entries} == {"not run"}
    assert len(entries) == len(claims(preset)) >= 19
    for e in entries:
        assert {"id", "claim", "table", "paper", "ours", "ci", "verdict"} <= set(e)


def test_tables_command_prints_tables_and_claims(capsys):
    from icil_paper.cli import main

    assert main(["tables", "--preset", "smoke", "--table", "IV"]) == 0
    out = capsys.readouterr().out
    assert "Table IV" in out and "not run" in out and "0.530" in out
    assert main(["tables", "--preset", "smoke", "--claims"]) == 0
    assert "[not run] I-lipvq-best" in capsys.readouterr().out
    assert main(["tables", "--preset", "smoke", "--table", "IX"]) == 2


@pytest.mark.sim
def test_a_table_is_computed_end_to_end_and_reruns_compute_nothing():
    from icil_paper.paper import run_tables
    from icil_paper.tables.cells import plan_done

    preset = get_preset("smoke").with_overrides(
        ["data.robocasa_tasks=kitchen/open_drawer,kitchen/close_drawer"])
    run_tables(preset, ["IV", "III"], executor="serial", progress=False)
    store = ResultsStore(preset.name)
    assert all(plan_done(store, p) for p in plan([table_spec(preset, "IV")]))
    table4 = assemble(table_spec(preset, "IV"), store)
    assert table4.complete
    smooth = assemble(table_spec(preset, "III"), store)
    cell = smooth.entry("icrt+lipvq", "least_energy")
    assert cell.estimate is not None and cell.extra["metrics"][0]["capped_fraction"] is not None
    assert run_tables(preset, ["IV", "III"], executor="serial", progress=False) == {}


def test_committed_reference_records_are_current_or_labelled_as_older_code(monkeypatch):
    """Every record under results/reference/ has a key the current code computes for one
    of the tables' cells, or the book says that it was made by older code: the introduction's
    summary counts the stale records, chapter 0 lists them, and the older code's ledger is
    kept with the commit that computed it. Nothing is deleted."""
    from icil_paper.book.report import (
        OLDER_RECORDS,
        older_ledger,
        reference_freshness,
        retired_records,
        stale_records,
    )
    from icil_paper.tables.design import read_record

    monkeypatch.setenv("ICIL_RESULTS", str(ROOT / "results"))
    stale = stale_records("reference")
    fresh = reference_freshness("reference")
    assert fresh["stale"] == len(stale) and fresh["current"] + fresh["stale"] == fresh["records"]
    record = read_record(ResultsStore("reference", root=ROOT / "results"))
    assert record is not None and record.get("protocol") != "kitchen"
    assert not stale, ("records of older code are left in the reference store: move them out "
                       "with `icil-paper tables --preset reference --retire-stale`")
    retired = retired_records("reference")
    if not retired:
        return
    moved = ROOT / "results" / "reference" / OLDER_RECORDS
    assert sum(retired.values()) == sum(1 for _ in moved.glob("*/*.json"))
    older = older_ledger("reference")
    assert older is not None, "stale reference records need the older code's ledger beside them"
    made_by, ledger = older
    assert len(made_by["commit"]) == 40 and ledger
    chapter = (ROOT / "notebooks" / "00_claims_ledger.py").read_text()
    assert "stale_records(REFERENCE)" in chapter and "older_ledger(REFERENCE" in chapter
    assert "retired_records(REFERENCE)" in chapter


def test_the_committed_reference_run_finished_within_its_budget():
    """Every cell the reference run planned has its records, no look sends a row on, and
    from the cells' own CPU times the run takes at most its budget at two cells at a time
    on 2 cores (`cost.json`, computed from the committed records)."""
    from icil_paper.book.report import run_progress

    progress = run_progress(ROOT / "results" / "reference" / "cost.json")
    assert progress is not None and progress["finished"] == progress["planned"] > 0
    assert not progress["more_stages"]
    assert progress["wall_hours"] <= progress["target_hours"]


def test_retiring_moves_only_stale_records_out_of_the_store_and_counts_them(tmp_path,
                                                                           monkeypatch):
    """`retire_stale_records` moves each stale record whole to older-code/records/<kind>/,
    keeps the current ones in place, counts the moved ones by commit, and a second call
    moves nothing."""
    from icil_paper.book import report as book
    from icil_paper.results import ResultsStore

    monkeypatch.setenv("ICIL_RESULTS", str(tmp_path))
    store = ResultsStore("reference")
    name = "icrt+lipvq__kitchen_open_door"
    old_path = store.write("eval", name, {"a": 1}, {"success_rate": 0.5}, seed=0, wall_time_s=1)
    new_path = store.write("eval", name, {"a": 2}, {"success_rate": 0.6}, seed=0, wall_time_s=1)
    old = json.loads(old_path.read_text())
    # both records share a name: only the one whose key is no longer computed may move
    current = json.loads(new_path.read_text())["config_hash"]
    monkeypatch.setattr(book, "current_keys", lambda preset_name: {current})
    moved = book.retire_stale_records("reference")
    assert moved == {str(old["git_commit"] or "unknown"): 1}
    target = store.dir / book.OLDER_RECORDS / "eval" / old_path.name
    assert not old_path.exists() and json.loads(target.read_text()) == old
    assert new_path.exists()
    assert book.retired_records("reference") == moved
    assert book.retire_stale_records("reference") == {}


@pytest.mark.sim
@pytest.mark.slow
@pytest.mark.ray
def test_the_executors_give_the_same_records(tmp_path, monkeypatch):
    """`icil-paper reproduce --stages table-IV` serial, on a local pool and on Ray: the same
    records (metrics without wall times), so a grid's numbers do not depend on how it ran."""
    from icil_paper.cli import main

    def records(folder):
        out = {}
        for path in sorted((folder / "smoke").glob("*/*.json")):
            if path.parent.name in ("environment", "claims"):
                continue
            record = json.loads(path.read_text())
            metrics = {k: v for k, v in record["metrics"].items() if "wall_time" not in k}
            for episode in metrics.get("per_episode", []):
                episode.pop("wall_time_s", None)
            out[path.name] = {k: v for k, v in metrics.items()
                              if k not in ("elapsed_s", "steps_per_s", "run_dir")}
        return out

    args = ["reproduce", "--preset", "smoke", "--stages", "table-IV",
            "--set", "data.robocasa_tasks=kitchen/open_drawer"]
    results = {}
    for executor in ("serial", "local", "ray"):
        monkeypatch.setenv("ICIL_RESULTS", str(tmp_path / executor))
        monkeypatch.setenv("ICIL_RUNS", str(tmp_path / f"runs-{executor}"))
        if executor == "ray":
            pytest.importorskip("ray", reason="Ray is not installed")
        assert main([*args, "--executor", executor, "--workers", "2"]) == 0
        results[executor] = records(tmp_path / executor)
    assert results["serial"] and results["serial"] == results["local"] == results["ray"]


@pytest.mark.parametrize("preset_name", ["small", "full"])
def test_fig5_rows_stand_beside_the_paper_by_position(preset_name):
    """The preset's i-th codebook size is compared with the paper's i-th (2^8 .. 2^11), and
    its label names the paper's size where the two differ."""
    from icil_paper.paper.table_iv import FIG5_CODEBOOK_SIZE

    f5 = table_spec(get_preset(preset_name), "fig5")
    assert [r.paper["avg"] for r in f5.rows] == [FIG5_CODEBOOK_SIZE[s] for s in
                                                 sorted(FIG5_CODEBOOK_SIZE)]
    if preset_name == "small":
        assert f5.rows[0].label == "2^6 (the paper's 2^8)"
    else:
        assert [r.label for r in f5.rows] == ["2^8", "2^9", "2^10", "2^11"]


def test_the_ledger_keeps_each_interval_on_one_line():
    """The book's ledger writes `ours [low, high]` with non-breaking spaces (a narrow column
    must not break an interval over lines)."""
    from icil_paper.book.report import ledger_frame

    entry = {"id": "x", "table": "I", "quantity": "a minus b", "paper": 0.05, "ours": 0.006,
             "ci": [-0.07, 0.058], "verdict": "inconclusive"}
    ours = ledger_frame([entry]).loc["x", "ours"]
    assert ours == "+0.006\u00a0[-0.070,\u00a0+0.058]" and " " not in ours


def test_scenes_per_seed_give_seed_k_its_own_scene_set():
    shared = table_spec(small_preset("tables.icrt_seeds=3"), "I")
    per_seed = table_spec(small_preset("tables.icrt_seeds=3", "tables.scenes_per_seed=true"), "I")
    cell, cell_k = shared.row("icrt+lipvq").entries["avg"], per_seed.row("icrt+lipvq").entries["avg"]
    assert {u.eval.seed for u in cell.units} == {0} and cell.scenes == "shared"
    assert {(u.seed_index, u.eval.seed) for u in cell_k.units} == {(0, 0), (1, 1), (2, 2)}
    assert cell_k.scenes == "per_seed"
    # Seed 0 keeps its scenes (and so its records); only the other seeds' evaluations move.
    first = {spec_key(u.eval) for u in cell.units if u.seed_index == 0}
    assert first == {spec_key(u.eval) for u in cell_k.units if u.seed_index == 0}


def test_committed_reference_ledger_is_what_the_current_code_computes():
    """results/reference/claims.json is regenerated whenever the statistics, the claims or
    the records change, as the run's claims stage writes it: at the seeds the staged run has
    reached (`as_run`, which chapter 0 reads too). A stale one would put old verdicts into
    the introduction."""
    from icil_paper.config import get_preset as preset_named
    from icil_paper.planning.staged import staged_preset
    from icil_paper.tables.design import read_record

    root = Path(__file__).resolve().parents[1] / "results"
    committed = json.loads((root / "reference" / "claims.json").read_text())["claims"]
    store = ResultsStore("reference", root=root)
    if (read_record(store) or {}).get("protocol") == "kitchen":
        # the kitchen run's ledger: its tasks are retired, so it is kept as it was computed
        ledger = json.loads((root / "reference" / "claims.json").read_text())
        assert ledger["design"]["name"] == "older" and len(committed) == 24
        return
    current = claims_ledger(staged_preset(preset_named("reference"), store)[0], store)
    assert json.loads(json.dumps([e.to_dict() for e in current])) == committed


def test_row_seeds_give_single_rows_their_own_seeds_and_refuse_unknown_rows():
    import dataclasses

    from icil_paper.config_data import ConfigError
    from icil_paper.paper import check_row_seeds
    from icil_paper.registry import UnknownNameError

    preset = small_preset("tables.icrt_seeds=2", "tables.row_seeds=I:icrt+mlp=4,II:*=3,beyond:icrt+fsq=5")
    t1, t2, beyond = (table_spec(preset, t) for t in ("I", "II", "beyond"))
    assert len(run_keys(t1, "icrt+mlp")) == 4 and len(run_keys(t1, "icrt+vq")) == 2
    assert len(run_keys(t1, "bc_transformer")) == 1  # baseline_seeds
    assert {len({u.run.key() for u in c.units}) for r in t2.rows
            for col, c in r.entries.items() if col != "avg"} == {3}
    assert len(run_keys(beyond, "icrt+fsq")) == 5
    # A row that shares Table I's runs has at least Table I's seeds, and the same first runs
    assert run_keys(t1, "icrt+lipvq") <= run_keys(beyond, "icrt+lipvq")
    check_row_seeds(preset)
    with pytest.raises(UnknownNameError, match="icrt\\+lipvq"):
        check_row_seeds(small_preset("tables.row_seeds=I:icrt+lipv=3"))
    with pytest.raises(UnknownNameError, match="table"):
        check_row_seeds(small_preset("tables.row_seeds=XI:icrt+lipvq=3"))
    with pytest.raises(ValueError, match="TABLE:row=N"):
        small_preset("tables.row_seeds=I:icrt+lipvq=0")
    with pytest.raises(ConfigError, match="TABLE:row=N"):
        dataclasses.replace(preset.tables, row_seeds=("icrt+lipvq=3",))


def test_cells_run_seed_major_so_a_stopped_run_keeps_rows_balanced(monkeypatch):
    from icil_paper.paper import run_tables
    from icil_paper.tables import cells

    captured = []
    monkeypatch.setattr(cells, "ensure_data", lambda *a, **k: None)
    monkeypatch.setattr(cells, "run_jobs", lambda fn, jobs, **k: captured.extend(jobs) or {})
    run_tables(small_preset("tables.icrt_seeds=3"), ["IV"], progress=False)
    seeds = [c.kwargs["run"]["seed"] for c in captured]
    assert len(captured) == 12 and seeds == sorted(seeds)


def test_chapter_0_renders_every_piece_of_the_committed_reference_ledger(monkeypatch):
    """Chapter 0 turns the committed reference ledger into prose, a forest plot and two
    tables; a claim of a shape the older ledgers lacked (an undecided row added since the
    paper, sized by its reference effect) once broke the book build. Every piece runs here on
    the ledger as committed."""
    import matplotlib

    matplotlib.use("Agg")
    from IPython.core.interactiveshell import InteractiveShell

    from icil_paper.book.report import (
        answering_ledger,
        forest_plot,
        ledger_frame,
        run_progress,
    )
    from icil_paper.planning.design import design_frame
    from icil_paper.planning.staged import as_run
    from icil_paper.tables.claims import summary

    monkeypatch.setenv("ICIL_RESULTS", str(ROOT / "results"))
    ledger = json.loads((ROOT / "results" / "reference" / "claims.json").read_text())["claims"]
    counts = summary(ledger)
    assert counts["claims"] == len(ledger) == len(ledger_frame(ledger, "details"))
    undecided = ledger_frame(ledger, "undecided")
    assert len(undecided) == sum(as_entry(e).adjusted_verdict in ("inconclusive", "too few seeds")
                                 for e in ledger)
    forest_plot(ledger, title="reference")
    for kind in ("verdicts", "power"):
        assert len(ledger_frame(ledger, kind)) == len(ledger)
    progress = run_progress()
    assert progress is not None and 0 <= progress["finished"] <= progress["planned"]
    assert len(design_frame(as_run(get_preset("reference"))))
    InteractiveShell.instance()  # display() outside a kernel prints; here it must not fail
    # the three questions are answered from the older protocol's ledger while none has run
    answering, made_by = answering_ledger()
    assert answering and (made_by is None) == any(as_entry(e).run for e in ledger)
