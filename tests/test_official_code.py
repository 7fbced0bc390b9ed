"""The official code's departures as options and as a table: its Bin's running range, prompts
from the minibatch, the official LipVQ-VAE's differences one field set at a time, and the
`official` table that measures them against Table I's rows."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from icil_paper.config import get_preset
from icil_paper.config_data import field_choices, to_dict
from icil_paper.paper import table_spec
from icil_paper.paper.official import OFFICIAL_ROWS, config_differences
from icil_paper.policies.batching import PROMPT_FROM, DemoSet, prompt_query_batch
from icil_paper.policies.configs import ICRTConfig
from icil_paper.records import eval_record_name, features_record
from icil_paper.results import ResultsStore
from icil_paper.runspec import run_spec
from icil_paper.sim.synthetic import synthetic_demos
from icil_paper.tables.assemble import assemble
from icil_paper.tokenizers import make_tokenizer
from icil_paper.tokenizers.bin import RANGES
from icil_paper.tokenizers.configs import (
    BinConfig,
    LipschitzOptions,
    LipVQConfig,
    lipvq_official,
    official_bin,
)

A = 7
PAPER_LIPVQ, PAPER_BIN = "icrt+lipvq (paper)", "icrt+bin (paper)"
VARIANTS = [row for row, base in OFFICIAL_ROWS if base is not None]


# ----------------------------------------------------------------------- the official Bin
def test_official_bin_has_20_bins_whose_edges_follow_the_running_min_and_max():
    config = official_bin(latent_dim=8)
    assert (config.n_bins, config.range) == (20, "running")
    assert config == BinConfig(latent_dim=8, n_bins=20, range="running")
    tok = make_tokenizer(config, 3)
    assert tok.fitted and not tok.needs_fit  # nothing is fitted before training
    assert tok.codebook_size == 3 * 20
    rng = np.random.default_rng(0)
    first = torch.from_numpy(rng.uniform(-0.5, 0.5, (2, 6, 3))).float()
    second = torch.from_numpy(rng.uniform(-2.0, 0.2, (2, 6, 3))).float()
    tok.train()
    tok(first)  # the first batch sets the range
    torch.testing.assert_close(tok.low, first.reshape(-1, 3).min(0).values)
    torch.testing.assert_close(tok.high, first.reshape(-1, 3).max(0).values)
    tok(second)  # later ones only widen it
    both = torch.cat([first, second]).reshape(-1, 3)
    torch.testing.assert_close(tok.low, both.min(0).values)
    torch.testing.assert_close(tok.high, both.max(0).values)
    torch.testing.assert_close(tok.bin_width, (tok.high - tok.low) / 20)
    codes = tok(both[None]).codes
    assert codes.min() == 0 and codes.max() == 19  # the extremes fall in the end bins
    # evaluation bins with the range training left, whatever it is given
    low, high = tok.low.clone(), tok.high.clone()
    tok.eval()
    below, above = tok(second - 100).codes, tok(second + 100).codes
    torch.testing.assert_close(tok.low, low)
    torch.testing.assert_close(tok.high, high)
    assert (below == 0).all() and (above == 19).all()
    # the range travels with the trained tokenizer
    again = make_tokenizer(config, 3)
    again.load_state_dict(tok.state_dict())
    assert torch.equal(again.eval()(second).codes, tok(second).codes)
    # `fit` reads nothing with a running range
    tok.fit(np.full((1, 4, 3), 100.0))
    torch.testing.assert_close(tok.low, low)


def test_the_paper_bin_still_fits_its_range_once_and_the_choices_match():
    assert field_choices(BinConfig)["range"] == RANGES == ("fixed", "running")
    tok = make_tokenizer(BinConfig(latent_dim=8), 3)
    assert tok.needs_fit and not tok.fitted and BinConfig().n_bins == 256
    data = np.random.default_rng(1).normal(size=(4, 10, 3))
    tok.fit(data).train()
    low = tok.low.clone()
    tok(torch.full((1, 2, 3), 50.0))  # training does not move a fitted range
    torch.testing.assert_close(tok.low, low)
    torch.testing.assert_close(low, torch.as_tensor(data.reshape(-1, 3).min(0), dtype=low.dtype))
    with pytest.raises(ValueError, match="range"):
        BinConfig(range="runing")


# ----------------------------------------------------------------------- minibatch prompts
def _demo_of(actions: np.ndarray, data: DemoSet) -> int:
    matches = [i for i, a in enumerate(data.actions)
               if len(a) == len(actions) and np.array_equal(a, actions)]
    assert len(matches) == 1
    return matches[0]


def test_minibatch_prompts_come_from_the_same_random_minibatch_whatever_their_task():
    assert field_choices(ICRTConfig)["prompt_from"] == PROMPT_FROM == ("same_task", "minibatch")
    data = DemoSet(synthetic_demos(n_tasks=3, per_task=4, steps=(8, 12), seed=0))
    other_task = 0
    for seed in range(20):
        B = 4
        batch = prompt_query_batch(data, B, 0, 2, 1, np.random.default_rng(seed),
                                   query_start="episode_start", prompt_from="minibatch")
        queries, prompts = [], []
        for b in range(B):
            n_q, n_p = int(batch["query_valid"][b].sum()), int(batch["prompt_valid"][b].sum())
            queries.append(_demo_of(batch["query_actions"][b, :n_q].numpy(), data))
            prompts.append(_demo_of(batch["prompt_actions"][b, :n_p].numpy(), data))
        # one minibatch of 2B distinct demonstrations: the first B prompt the last B
        assert len(set(queries) | set(prompts)) == 2 * B
        rng = np.random.default_rng(seed)
        drawn = rng.choice(len(data), size=2 * B, replace=False).tolist()
        assert prompts == drawn[:B] and queries == drawn[B:]
        other_task += sum(data.tasks[p] != data.tasks[q] for p, q in zip(prompts, queries,
                                                                           strict=True))
    assert other_task > 0  # a prompt may show another task than its query
    same = prompt_query_batch(data, 8, 0, 2, 1, np.random.default_rng(0))
    for b in range(8):  # the default: the query's task
        n_q, n_p = int(same["query_valid"][b].sum()), int(same["prompt_valid"][b].sum())
        q = _demo_of(same["query_actions"][b, :n_q].numpy(), data)
        p = _demo_of(same["prompt_actions"][b, :n_p].numpy(), data)
        assert data.tasks[p] == data.tasks[q] and p != q
    with pytest.raises(ValueError, match="prompt_from"):
        prompt_query_batch(data, 2, 0, 2, 1, np.random.default_rng(0), prompt_from="task")


def test_minibatch_prompts_with_two_prompt_demos_and_a_small_data_set():
    data = DemoSet(synthetic_demos(n_tasks=2, per_task=2, steps=6, seed=3))
    batch = prompt_query_batch(data, 3, 0, 1, 2, np.random.default_rng(0),
                               prompt_from="minibatch")  # 9 > 4 demonstrations: repeats
    assert batch["prompt_actions"].shape[:2] == (3, 12)  # two whole demonstrations each
    assert batch["query_actions"].shape[:2] == (3, 6)


def test_icrt_trains_with_minibatch_prompts_and_the_official_bin():
    from icil_paper.train import train_policy

    demos = synthetic_demos(n_tasks=2, per_task=3, steps=(10, 14), seed=0)
    preset = get_preset("smoke").replace(policies={"icrt": dataclasses.replace(
        get_preset("smoke").policies.icrt, prompt_from="minibatch")})
    spec = run_spec(preset, "icrt", official_bin(16), tasks=("synthetic/task0",
                                                             "synthetic/task1"))
    result = train_policy(spec.replace(train=dataclasses.replace(spec.train, steps=3)),
                          run_dir=None, demos=demos, progress=False)
    tok = result.policy.tokenizer
    seen = np.concatenate([d.actions for d in demos])
    assert bool(tok._range_seen)
    # within what training could see (a constant dimension is widened by 1e-3)
    assert (tok.low.numpy() >= seen.min(0) - 1.1e-3).all()
    assert (tok.high.numpy() <= seen.max(0) + 1.1e-3).all()


# ----------------------------------------------------------------------- the official LipVQ-VAE
def test_each_official_lipvq_difference_is_a_config_change_that_builds_and_works():
    paper = LipVQConfig(latent_dim=16, codebook_size=32)
    official = lipvq_official(16, 32)
    assert set(config_differences(official, paper)) == {
        "norm", "activation", "output_activation", "straight_through", "detach_embeddings",
        "codebook_weight", "decoder_hidden", "lipschitz.weight", "lipschitz.per_row",
        "lipschitz.c_init", "lipschitz.weight_init"}
    actions = torch.from_numpy(np.random.default_rng(0).normal(size=(2, 5, A))).float()
    last = dataclasses.replace(paper, norm="lipschitz-last", output_activation="sigmoid",
                               lipschitz=LipschitzOptions(per_row=True, c_init=1.0,
                                                          weight_init="randn"))
    tok = make_tokenizer(last, A)
    from icil_paper.tokenizers import lipschitz_layers

    layers = lipschitz_layers(tok.encoder)
    assert len(layers) == 1 and layers[0] is tok.encoder[-2] and layers[0].per_row
    assert isinstance(tok.encoder[-1], torch.nn.Sigmoid)
    out = tok(actions)
    assert "lipschitz" in out.losses and 0 <= out.latents.min() and out.latents.max() <= 1
    detached = make_tokenizer(dataclasses.replace(paper, detach_embeddings=True), A)(actions)
    assert not detached.embeddings.requires_grad
    assert make_tokenizer(paper, A)(actions).embeddings.requires_grad
    no_loss = make_tokenizer(dataclasses.replace(
        paper, lipschitz=LipschitzOptions(weight=0.0)), A)(actions)
    assert "lipschitz" not in no_loss.losses and "lipschitz" in make_tokenizer(paper, A)(
        actions).losses


# ----------------------------------------------------------------------- the table
EXPECTED_CHANGES = {
    "icrt+lipvq (official code)": {
        "tokenizer." + f for f in ("norm", "activation", "output_activation",
                                   "straight_through", "detach_embeddings", "codebook_weight",
                                   "decoder_hidden", "lipschitz.weight", "lipschitz.per_row",
                                   "lipschitz.c_init", "lipschitz.weight_init")},
    "last layer only": {"tokenizer.norm", "tokenizer.output_activation",
                        "tokenizer.lipschitz.per_row", "tokenizer.lipschitz.c_init",
                        "tokenizer.lipschitz.weight_init"},
    "detached latent": {"tokenizer.detach_embeddings"},
    "no Lipschitz loss": {"tokenizer.lipschitz.weight"},
    "icrt+bin (official code)": {"tokenizer.n_bins", "tokenizer.range"},
    "prompts from the minibatch": {"policy.prompt_from"},
}


def _changes(a, b) -> set[str]:
    assert (a.data, a.train, a.seed) == (b.data, b.train, b.seed)
    out = {f"policy.{k}" for k in config_differences(a.policy, b.policy)}
    assert type(a.tokenizer) is type(b.tokenizer)
    return out | {f"tokenizer.{k}" for k in config_differences(a.tokenizer, b.tokenizer)}


@pytest.mark.parametrize("preset_name", ["smoke", "small", "reference"])
def test_each_variant_differs_from_the_papers_row_in_exactly_the_fields_it_names(preset_name):
    spec = table_spec(get_preset(preset_name), "official")
    assert [r.label for r in spec.rows] == [row for row, _ in OFFICIAL_ROWS]
    bases = dict(OFFICIAL_ROWS)
    assert set(EXPECTED_CHANGES) == set(VARIANTS)
    for variant in VARIANTS:
        units = spec.row(variant).entries["avg"].units
        seeds = {u.seed_index for u in units}  # the paper's rows may have Table I's more seeds
        base_units = [u for u in spec.row(bases[variant]).entries["avg"].units
                      if u.seed_index in seeds]
        assert [u.eval for u in units] == [u.eval for u in base_units]  # the same episodes
        for u, b in zip(units, base_units, strict=True):
            assert _changes(u.run, b.run) == EXPECTED_CHANGES[variant], variant
    official = spec.row("icrt+lipvq (official code)").entries["avg"].units[0].run.tokenizer
    preset = get_preset(preset_name)
    expected = lipvq_official(preset.tokenizers.lipvq.latent_dim,
                              preset.tokenizers.lipvq.codebook_size)
    # the bounds' learning-rate multiple is the preset's budget adaptation (they travel as
    # far as over the paper's 500K iterations), not a difference of the official code
    scale = preset.tokenizers.lipvq.lipschitz.c_lr_scale
    assert official == dataclasses.replace(expected, lipschitz=dataclasses.replace(
        expected.lipschitz, c_lr_scale=scale))


def test_the_paper_rows_are_table_is_runs_and_the_reference_plans_five_seeds():
    from icil_paper.tables.cells import plan

    preset = get_preset("reference")
    official, table1, beyond = (table_spec(preset, t) for t in ("official", "I", "beyond"))
    t1_seeds = preset.tables.icrt_seeds  # the paper's rows are Table I's runs, all of them
    for row in official.rows:
        want = t1_seeds if row.label in (PAPER_LIPVQ, PAPER_BIN) else 5
        assert {c.seeds for c in row.entries.values()} == {want}, row.label
        assert row.entries["features"].units[0].features is not None
    for ours, theirs in ((PAPER_LIPVQ, "icrt+lipvq"), (PAPER_BIN, "icrt+bin")):
        shared = {(u.run.key(), u.eval) for u in official.row(ours).entries["avg"].units}
        t1 = {(u.run.key(), u.eval) for u in table1.row(theirs).entries["avg"].units}
        assert t1 <= shared  # Table I's seeds, on the same episodes
        assert official.row(ours).paper == table1.row(theirs).paper
    t1_runs = {u.run.key() for u in table1.units()}
    for variant in VARIANTS:
        assert not {u.run.key() for u in official.row(variant).entries["avg"].units} & t1_runs
    seeds = preset.tables.official_seeds
    base = len(plan([table1, beyond]))
    # six variants of five seeds each; the paper's rows are Table I's runs, all of them
    assert len(plan([table1, beyond, official])) == base + 6 * seeds
    assert len(plan([table1, official])) == len(plan([table1])) + 6 * seeds


def test_the_official_table_key_reads_only_its_own_fields():
    from icil_paper.config_data import keyed_paths
    from test_specs import leaf_paths, perturbed, units_key

    def key_of(p):
        return units_key(table_spec(p, "official").units())

    reads = ("policies.icrt.", "tokenizers.lipvq.", "tokenizers.bin.", "train.",
             "data.demos_per_task", "data.task_demos", "data.obs", "data.robocasa_tasks", "seed",
             "eval.episodes_per_task", "eval.max_steps", "tables.icrt_seeds",
             "tables.official_seeds", "tables.row_seeds",  # the paper's rows: Table I's seeds
             "tables.feature_demos_per_task", "tables.feature_steps")
    preset = get_preset("small")
    base, keyed = key_of(preset), set(keyed_paths(preset))
    wrong = []
    for path in leaf_paths(preset):
        if path == "name":
            continue
        if (key_of(perturbed(preset, path)) != base) != (path in keyed and path.startswith(reads)):
            wrong.append(path)
    assert not wrong


def _fake_records(preset, store, rate_of, codes_of):
    """An eval record for every unit (success drawn with rate_of(row)) and a features record
    for every seed (codes_of(row) codes used)."""
    spec = table_spec(preset, "official")
    rng = np.random.default_rng(0)
    for row in spec.rows:
        for unit in row.entries["avg"].units:
            n = unit.eval.episodes
            per = [{"episode": i, "success": bool(rng.random() < rate_of(row.label)),
                    "steps": 5} for i in range(n)]
            store.write("eval", eval_record_name(unit.run, unit.eval),
                        {"run": to_dict(unit.run, keyed_only=True),
                         "eval": to_dict(unit.eval, keyed_only=True)},
                        {"task": unit.eval.task, "episodes": n, "per_episode": per,
                         "successes": sum(e["success"] for e in per)},
                        seed=unit.run.seed, wall_time_s=0.0)
        for unit in row.entries["features"].units:
            kind, name, config = features_record(unit.run, unit.features)
            scores = rng.uniform(0.5, 1.5, 4).tolist()
            store.write(kind, name, config, {
                "least_energy_per_trajectory": scores,
                "least_energy_standardized_per_trajectory": scores, "latent_scale": 0.3,
                "view": [[0.0]], "codes_used": codes_of(row.label), "codebook_size": 64},
                seed=unit.run.seed, wall_time_s=0.0)


def test_findings_give_each_variant_against_its_base_with_a_verdict_and_the_codes():
    from icil_paper.paper.official import (
        codes_frame,
        collapsed_rows,
        differences_frame,
        findings,
        findings_frame,
    )

    kitchen = "data.robocasa_tasks=kitchen/open_drawer,kitchen/close_drawer,kitchen/open_door"
    rates = {"icrt+lipvq (official code)": 0.1, "prompts from the minibatch": 0.95}
    codes = {"icrt+lipvq (official code)": 1, "detached latent": 1}
    for seeds, expect in ((1, "too few seeds"), (3, None)):
        preset = get_preset("smoke").with_overrides(
            [kitchen, "eval.episodes_per_task=40", f"tables.official_seeds={seeds}"])
        store = ResultsStore(preset.name)
        result = assemble(table_spec(preset, "official"), store)
        assert {f["verdict"] for f in findings(result)} == {"not run"}
        _fake_records(preset, store, lambda r: rates.get(r, 0.5), lambda r: codes.get(r, 20))
        result = assemble(table_spec(preset, "official"), store)
        found = {f["variant"]: f for f in findings(result)}
        assert list(found) == VARIANTS
        assert all(f["base"] == dict(OFFICIAL_ROWS)[v] for v, f in found.items())
        off = found["icrt+lipvq (official code)"]
        assert off["estimate"].value < -0.2 and off["seeds"] == {
            "icrt+lipvq (official code)": seeds, PAPER_LIPVQ: seeds}
        assert off["variant_codes"] == [1] * seeds and off["base_codes"] == [20] * seeds
        if expect:
            assert {f["verdict"] for f in found.values()} == {expect}
            assert {f["adjusted_verdict"] for f in found.values()} == {expect}
        else:
            assert off["verdict"] == off["adjusted_verdict"] == "does not hold"
            assert found["prompts from the minibatch"]["adjusted_verdict"] == "holds"
        assert collapsed_rows(result) == ["icrt+lipvq (official code)", "detached latent"]
        frame = findings_frame(result)
        assert list(frame.index) == VARIANTS and frame.loc["detached latent", "codes used"] == "1"
        assert codes_frame(result).loc[PAPER_BIN, "codebook"] == "64"
    diffs = differences_frame(result)
    assert set(diffs.loc["prompts from the minibatch"].index) == {"policy.prompt_from"}
    assert set(diffs.loc["icrt+bin (official code)"].index) == {"tokenizer.n_bins",
                                                                 "tokenizer.range"}


def test_the_official_table_is_a_reproduce_stage_a_chapter_and_prints(capsys):
    from pathlib import Path

    from icil_paper.cli import main
    from icil_paper.reproduce import STAGES

    assert "table-official" in [s.name for s in STAGES]
    root = Path(__file__).resolve().parents[1]
    chapter = root / "notebooks" / "13_paper_vs_official_code.py"
    assert 'load_table(preset, "official")' in chapter.read_text()
    assert "notebooks/13_paper_vs_official_code" in (root / "_toc.yml").read_text()
    assert main(["tables", "--preset", "smoke", "--table", "official"]) == 0
    out = capsys.readouterr().out
    assert "official code" in out and "prompts from the minibatch" in out and "not run" in out
    assert "0.530" in out  # Table I's LipVQ-VAE number, the paper's
