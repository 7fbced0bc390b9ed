"""The paper's regime at our budget: every policy reads the instruction, every training seed
its own demonstration set, twins that differ only by Eq. 4, bounds that can move."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from icil_paper.config import PRESET_NAMES, get_preset
from icil_paper.data.generate import demo_path
from icil_paper.data.sources import demo_seed
from icil_paper.paper.table_i import TABLE_I_ROWS
from icil_paper.policies import make_policy
from icil_paper.sim.synthetic import synthetic_demos
from icil_paper.tables.definitions import table_i_runs

torch.set_num_threads(1)
SPEC = {"proprio": 9, "object": 6}


@pytest.mark.parametrize("name", PRESET_NAMES)
def test_every_policy_of_every_preset_reads_the_instruction(name):
    preset = get_preset(name)
    for policy in preset.policies.REGISTRY.configs:
        assert preset.policies.get(policy).language, (name, policy)


@pytest.mark.parametrize("name", ["icrt", "bc_transformer", "act"])
def test_the_instruction_changes_what_a_policy_predicts(name):
    """The same batch with the instructions of two tasks gives two losses: the policy reads
    its instruction (a policy that dropped it would give one)."""
    demos = synthetic_demos(n_tasks=2, per_task=3, steps=(12, 20), seed=0)
    config = get_preset("smoke").policies.get(name)
    if name == "icrt":
        config = dataclasses.replace(config, query_len=6)
    tokenizer = get_preset("smoke").tokenizers.get("mlp") if name == "icrt" else None
    torch.manual_seed(0)
    policy = make_policy(config, SPEC, 7, tokenizer)
    data = policy.prepare(demos)
    policy.eval()
    batch = policy.sample_batch(data, 2, np.random.default_rng(0))
    losses = []
    for text in ("reach goal number 0", "press the button on the appliance"):
        batch = {**batch, "instruction": [text] * len(batch["instruction"])}
        torch.manual_seed(1)  # ACT's latent sample
        with torch.no_grad():
            losses.append(float(policy(batch)[0]))
    assert losses[0] != losses[1]


def test_two_seeds_of_a_row_train_on_different_demonstration_files():
    preset = get_preset("reference")
    runs = {f"{p}+{t}": table_i_runs(preset, p, t) for p, t in TABLE_I_ROWS if p != "mcr"}
    task = preset.data.robocasa_tasks[0]
    for label, row in runs.items():
        files = [demo_path(preset, task, r.data.source, r.data.obs, seed=r.data.seed)
                 for r in row]
        assert len(set(files)) == len(files), label  # every seed its own file
        # ... and its own scenes: no expert seed of set k is one of set j's
        n = preset.data.demos_per_task + preset.tables.feature_demos_per_task
        scenes = [{demo_seed(r.data.seed, "generated", i) for i in range(n)} for r in row]
        assert all(not (a & b) for i, a in enumerate(scenes) for b in scenes[i + 1:]), label
    first, *others = runs.values()
    for other in others:  # seed k of every row: the same data set
        assert [r.data for r in other[:3]] == [r.data for r in first[:3]]


TWINS = (("mlp", "lip-mlp"), ("vq", "lipvq"), ("fsq", "lipfsq"), ("rvq", "liprvq"))


def _icrt(preset, tokenizer, seed=0):
    from icil_paper.seeding import seed_everything

    seed_everything(seed)
    config = dataclasses.replace(preset.policies.icrt, query_len=6)
    return make_policy(config, SPEC, 7, preset.tokenizers.get(tokenizer))


@pytest.mark.parametrize("plain, lipschitz", TWINS)
def test_a_lipschitz_tokenizer_starts_as_its_plain_twin(plain, lipschitz):
    """Under one seed, Lip-MLP is MLP at step 0 (LipVQ-VAE is VQ-VAE, ...): the same
    weights, no row capped, the same embeddings; only Eq. 4's cap and loss differ later."""
    from icil_paper.tokenizers.lipschitz_linear import lipschitz_layers

    preset = get_preset("reference")
    a, b = _icrt(preset, plain), _icrt(preset, lipschitz)
    layers = lipschitz_layers(b.tokenizer)
    assert layers and all(float(torch.nn.functional.softplus(layer.c.detach()))
                          >= float(layer.weight.abs().sum(1).max()) for layer in layers)
    x = torch.randn(4, 9, 7)
    with torch.no_grad():
        za, zb = a.tokenizer(x).embeddings, b.tokenizer(x).embeddings
    assert torch.equal(za, zb)
    # Liu et al.'s initialisation (the analysis row) is another function at step 0
    liu = dataclasses.replace(preset.tokenizers.get(lipschitz), lipschitz=dataclasses.replace(
        preset.tokenizers.get(lipschitz).lipschitz, weight_init="liu"))
    torch.manual_seed(0)
    other = make_policy(dataclasses.replace(preset.policies.icrt, query_len=6), SPEC, 7, liu)
    with torch.no_grad():
        assert not torch.allclose(other.tokenizer(x).embeddings, za)


def test_every_icrt_row_starts_from_the_same_backbone():
    """Common random numbers: under one seed, every ICRT row's observation encoder,
    transformer and head start from the same weights whatever its tokenizer."""
    from icil_paper.tables.definitions import ICRT_TOKENIZERS

    preset = get_preset("reference")
    policies = [_icrt(preset, tok) for tok in (*ICRT_TOKENIZERS, "lip-mlp")]
    for part in ("obs_encoder", "transformer", "head", "action_proj", "type_emb"):
        first = getattr(policies[0], part).state_dict()
        for policy in policies[1:]:
            other = getattr(policy, part).state_dict()
            assert all(torch.equal(first[k], other[k]) for k in first), part
    assert not torch.equal(_icrt(preset, "mlp", seed=1).head[0].weight,
                           policies[0].head[0].weight)


def test_the_regime_pilot_uses_seeds_data_and_scenes_the_reference_run_does_not():
    from icil_paper.paper import table_spec
    from icil_paper.tables.cells import plan
    from tools.pilot import REGIME_ROWS, regime_plans, regime_preset

    preset = get_preset("reference")
    reference = plan([table_spec(preset, "I")])
    used = ({p.run.seed for p in reference}, {p.run.data.seed for p in reference},
            {ev.seed for p in reference for ev in p.evals.values()})
    pilot = regime_plans(regime_preset(10, 500), seeds=2)
    assert {p.run.label for p in pilot} == {f"{a}+{b}" if b else a for a, b in REGIME_ROWS}
    mine = ({p.run.seed for p in pilot}, {p.run.data.seed for p in pilot},
            {ev.seed for p in pilot for ev in p.evals.values()})
    for ours, theirs in zip(mine, used, strict=True):
        assert ours and not ours & theirs
    # the bounds' rate follows the pilot's budget as the presets' follows theirs
    chosen = regime_preset(preset.data.demos_per_task, preset.train.steps,
                           task_demos=preset.data.task_demos)
    assert chosen.data == preset.data
    assert chosen.tokenizers.lipvq.lipschitz.c_lr_scale == pytest.approx(
        preset.tokenizers.lipvq.lipschitz.c_lr_scale)
    assert regime_preset(10, preset.train.steps // 4).tokenizers.lipvq.lipschitz.c_lr_scale \
        > 3 * preset.tokenizers.lipvq.lipschitz.c_lr_scale


def test_the_plateau_is_the_first_budget_the_next_one_does_not_beat_beyond_noise():
    from tools.pilot import plateau

    rising = {500: [0.2, 0.25], 1000: [0.5, 0.55], 2000: [0.7, 0.72], 4000: [0.71, 0.73]}
    assert plateau(rising, episodes=55) == 2000
    assert plateau({500: [0.1, 0.1], 1000: [0.4, 0.41], 2000: [0.8, 0.79]}, 55) is None
    assert plateau({500: [0.3], 1000: [0.32], 2000: [0.6]}, 55) == 500  # binomial noise


def test_the_budget_is_the_plateau_unless_its_families_sit_at_0_or_1():
    from tools.pilot import REGIME_MIN_FAMILIES, choose_budget

    ok, few = REGIME_MIN_FAMILIES, REGIME_MIN_FAMILIES - 1
    assert choose_budget(1000, 2000, {500: ok, 1000: ok, 2000: few}) == (1000, "plateau")
    assert choose_budget(1000, 2000, {500: ok, 1000: few, 2000: few}) == (
        500, "in range below the plateau")
    assert choose_budget(None, 2000, {500: few, 1000: few, 2000: few}) == (2000, "last budget")
    assert choose_budget(None, 2000, {500: ok, 1000: ok, 2000: few}) == (
        1000, "in range below the last budget")


def test_the_plan_generates_one_demonstration_set_per_training_seed(tmp_path):
    import json

    from icil_paper.paper import TABLES, table_spec
    from icil_paper.planning.design import data_cost
    from icil_paper.tables.cells import plan

    rates = tmp_path / "datasets.json"
    rates.write_text(json.dumps({"suites": {"kitchen": {"cpu_s_per_demo": 1.0},
                                            "metaworld": {"cpu_s_per_demo": 1.0},
                                            "maniskill": {"cpu_s_per_demo": 2.0}}}))
    for name, sets in (("small", 1), ("reference", 10)):
        preset = get_preset(name)
        cost = data_cost(plan([table_spec(preset, t) for t in TABLES]), rates)
        assert cost["demonstration_sets"] == sets
        assert cost["core_s"] >= cost["demos"] * 1.0 > 0  # every demo priced (images more)


def test_seed_correlations_pair_rows_by_seed_index():
    from icil_paper import stats
    from icil_paper.paper import table_spec
    from icil_paper.tables.assemble import EntryResult, TableResult
    from icil_paper.tables.display import seed_correlations

    spec = table_spec(get_preset("smoke"), "IV")
    labels = [row.label for row in spec.rows]
    rates = {labels[0]: [0.2, 0.4, 0.6, 0.8], labels[1]: [0.3, 0.5, 0.7, 0.9],
             labels[2]: [0.9, 0.7, 0.5, 0.3], labels[3]: [0.5, 0.5, 0.5]}
    cells = {}
    for label, per_seed in rates.items():
        data = np.zeros((len(per_seed), 2, 10), bool)
        for s, rate in enumerate(per_seed):
            data[s, :, :round(rate * 10)] = True
        cells[label, "avg"] = EntryResult(stats.success_rate(data), data, 0)
    r = seed_correlations(TableResult(spec, cells, "smoke"))
    assert r[labels[0], labels[1]] == pytest.approx(1.0)
    assert r[labels[0], labels[2]] == pytest.approx(-1.0)
    assert not any(labels[3] in pair for pair in r)  # a constant row has no correlation


def test_the_committed_regime_pilot_has_every_part_the_regime_is_chosen_from():
    """`results/bench/regime.json`: the Meta-World suite, the data curve over at least three
    counts, the budget chosen from ICRT + LipVQ-VAE's learning curve over at least three
    budgets, every family of the rows beside it with their per-episode outcomes for at
    least three seeds; its seeds are not the reference run's, and the reference preset
    trains at its choice."""
    import json

    from icil_paper.results import bench_path
    from icil_paper.tables.definitions import FAMILY_COLUMNS
    from tools.pilot import REGIME_ROWS, REGIME_SEED

    record = json.loads(open(bench_path("regime")).read())
    reference = get_preset("reference")
    assert record["suite"] == "metaworld"
    assert record["tasks"] == list(reference.data.robocasa_tasks)
    data_curve = record["data_curve"]
    assert len(data_curve["counts"]) >= 3
    assert None not in data_curve["curve"].values()
    assert record["train_steps"] in record["budgets"] and record["demos_per_task"] >= 1
    curve = record["learning_curve"]["icrt+lipvq"]
    assert sum(v is not None for v in curve.values()) >= 3
    for policy, tokenizer in REGIME_ROWS:
        row = f"{policy}+{tokenizer}" if tokenizer else policy
        assert set(record["families"][row]) == set(FAMILY_COLUMNS), row
        assert None not in record["families"][row].values(), row
        outcomes = record["outcomes"][row]
        assert len(outcomes) >= 3 and None not in outcomes.values(), row
        for per_task in outcomes.values():
            assert set(per_task) == set(record["tasks"])
            assert {len(v) for v in per_task.values()} == {record["episodes_per_task"]}
    assert min(record["seed_indices"]) >= REGIME_SEED
    # the reference preset trains at the pilot's choice
    from icil_paper.config import task_demo_counts

    assert (reference.data.demos_per_task, reference.train.steps) == (
        record["demos_per_task"], record["train_steps"])
    assert task_demo_counts(reference.data.task_demos) == record.get("task_demos", {})


def test_the_regime_summary_names_the_families_and_maniskill_tasks_outside_the_range(tmp_path):
    import json

    from icil_paper.planning.pilot import regime_summary

    record = {"families": {"icrt+lipvq": {"doors": 0.5, "knobs": 1.0}},
              "learning_curve": {"icrt+lipvq": {"1000": 0.4, "2000": 0.5, "3000": 0.5}},
              "within_range": {"doors": True, "knobs": False}, "train_steps": 2000,
              "plateau_reached": True, "seeds": 2, "seed_indices": [20, 21],
              "demos_per_task": 3, "task_demos": {"metaworld/pick-place": 10},
              "budgets": [1000, 2000, 3000],
              "capped_share": {"icrt+lipvq": [0.3, 0.4]},
              "maniskill": {"act+lipvq": {"pick_cube": 0.5, "stack_cube": 0.0}}}
    path = tmp_path / "regime.json"
    path.write_text(json.dumps(record))
    frame, text = regime_summary(str(path))
    assert list(frame.index) == ["icrt+lipvq"]
    assert "levels off at 2000 steps" in text and "[0.1, 0.9]: knobs." in text
    assert "3 demonstrations a task (pick-place 10);" in text
    assert "pick_cube 0.5, stack_cube 0.0 (outside [0.1, 0.9]: stack_cube)" in text
