"""Evaluation: Wilson intervals, deterministic episodes and prompts, parallel workers,
recordings, the CLI record; and, with the simulator, every policy x tokenizer combination
trained a few steps and rolled out for one short episode under the smoke preset."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import torch

from icil_paper.config import get_preset
from icil_paper.eval import EvalResult, episode_seed, evaluate_policy
from icil_paper.policies.configs import ICRTConfig
from icil_paper.runspec import EvalSpec, run_spec
from icil_paper.sim.synthetic import make_synthetic_env, synthetic_demos
from icil_paper.tokenizers import TOKENIZERS
from icil_paper.train import train_policy
from oracle_policy import OraclePolicy

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def demos():
    return synthetic_demos(n_tasks=2, per_task=3, steps=30, seed=0)


def oracle():
    return OraclePolicy(ICRTConfig(), {"proprio": 9, "object": 6}, 7)


def trained(tokenizer, demos, policy="icrt"):
    spec = run_spec(get_preset("smoke"), policy, tokenizer,
                    tasks=["synthetic/task0", "synthetic/task1"])
    return train_policy(spec, run_dir=None, demos=demos, progress=False).policy


def synthetic(policy, task, prompts, **spec):
    """Roll `policy` out on a synthetic task in this process."""
    return evaluate_policy(policy, EvalSpec(task=task, **spec), prompts=prompts,
                           env_factory=make_synthetic_env, progress=False)


def test_oracle_succeeds_with_the_right_prompt(demos):
    task1 = [d for d in demos if d.task == "synthetic/task1"]
    result = synthetic(oracle(), "synthetic/task1", task1, episodes=4, seed=3, max_steps=40)
    assert isinstance(result, EvalResult)
    assert result.success_rate == 1.0 and result.successes == 4
    assert result.ci_high == 1.0 and 0.4 < result.ci_low < 1.0
    episodes = result.per_episode
    assert [e["seed"] for e in episodes] == [episode_seed(3, i) for i in range(4)]
    assert all(set(e["prompt"]) <= set(range(len(task1))) for e in episodes)
    assert result.outcomes.tolist() == [True] * 4
    assert EvalResult.from_dict(json.loads(json.dumps(result.to_dict()))) == result


def test_the_wrong_prompt_fails(demos):
    wrong = [d for d in demos if d.task == "synthetic/task0"]
    result = synthetic(oracle(), "synthetic/task1", wrong, episodes=2, max_steps=20)
    assert result.success_rate == 0.0
    assert all(e["steps"] == 20 for e in result.per_episode)


def test_same_seed_same_episodes(demos):
    policy = trained("lipvq", demos)
    ev = EvalSpec(task="synthetic/task0", episodes=3, seed=1, max_steps=6)
    kw = dict(prompts=demos, env_factory=make_synthetic_env, progress=False)
    one = evaluate_policy(policy, ev, **kw)
    again = evaluate_policy(policy, ev, **kw)

    def strip(r):
        return [{k: v for k, v in e.items() if k != "wall_time_s"} for e in r.per_episode]

    assert strip(one) == strip(again)
    other = evaluate_policy(policy, EvalSpec(task="synthetic/task0", episodes=3, seed=2,
                                             max_steps=6), **kw)
    assert [e["seed"] for e in strip(other)] != [e["seed"] for e in strip(one)]


def test_record_writes_a_recording_per_rollout(tmp_path, demos):
    policy = trained("vq", demos)
    result = evaluate_policy(policy, EvalSpec(task="synthetic/task0", episodes=2, max_steps=4),
                             prompts=demos, record_dir=tmp_path, env_factory=make_synthetic_env,
                             progress=False)
    paths = [e["recording"] for e in result.per_episode]
    assert len(set(paths)) == 2 and all(p and (tmp_path / p).exists() for p in paths)


def test_bad_arguments_raise(demos):
    with pytest.raises(ValueError, match="episodes"):
        synthetic(oracle(), "synthetic/task0", demos, episodes=0)
    with pytest.raises(ValueError, match="max_steps"):
        synthetic(oracle(), "synthetic/task0", demos, episodes=1, max_steps=0)
    with pytest.raises(ValueError, match="needs prompt demonstrations"):
        synthetic(oracle(), "synthetic/task0", [], episodes=1)
    bad = [dataclasses.replace(demos[0], actions=demos[0].actions[:, :5])]
    with pytest.raises(ValueError, match="wrong action dimension"):
        synthetic(oracle(), "synthetic/task0", bad, episodes=1)


def test_a_policy_of_another_suite_is_refused_before_rollouts(demos):
    from icil_paper.eval import check_policy_fits

    policy = trained("mlp", demos)  # 9 + 6 wide state, the kitchen gives 9 + 18
    with pytest.raises(ValueError, match="15-dimensional state.*gives 27"):
        check_policy_fits(policy, "kitchen/open_drawer")


def test_eval_cli_stores_one_record_per_task(tmp_path, demos, monkeypatch):
    import icil_paper.eval.cli as eval_cli
    import icil_paper.eval.stored as stored
    from icil_paper.results import ResultsStore
    from icil_paper.train import run_dir_for
    from icil_paper.train.stored import train_run

    monkeypatch.setenv("ICIL_RUNS", str(tmp_path))
    spec = run_spec(get_preset("smoke"), "icrt", "mlp",
                    tasks=["kitchen/open_drawer", "kitchen/close_drawer"])
    # with its train record: evaluation trusts a policy file only with the record naming it
    train_run(spec, "smoke", ResultsStore("smoke"), run_dir=run_dir_for(spec, "smoke"),
              demos=demos, progress=False)
    calls = []
    real = stored.evaluate_policy

    def on_synthetic(policy, ev, **kw):
        calls.append(ev.task)
        return real(policy, dataclasses.replace(ev, task="synthetic/task0"),
                    **{**kw, "env_factory": make_synthetic_env})

    monkeypatch.setattr(stored, "evaluate_policy", on_synthetic)
    monkeypatch.setattr(stored, "prompt_pool", lambda *a, **k: demos)
    # the policy learnt synthetic demos and acts in the synthetic env: the kitchen widths
    # do not apply
    monkeypatch.setattr(eval_cli, "check_policy_fits", lambda policy, task: None)
    argv = ["--preset", "smoke", "--tasks", "kitchen/open_drawer", "kitchen/close_drawer",
            "--train-tasks", "kitchen/open_drawer", "kitchen/close_drawer",
            "--episodes", "2", "--workers", "1", "--quiet"]
    assert eval_cli.main(argv) == 0
    assert eval_cli.main(argv) == 0  # the second run loads the stored records
    assert calls == ["kitchen/open_drawer", "kitchen/close_drawer"]
    records = ResultsStore("smoke").records("eval")
    assert sorted(r["name"] for r in records) == [
        "icrt+mlp__kitchen/close_drawer__generated__seed0",
        "icrt+mlp__kitchen/open_drawer__generated__seed0"]
    m = records[0]["metrics"]
    assert m["episodes"] == 2 and 0 <= m["ci_low"] <= m["success_rate"] <= m["ci_high"] <= 1
    assert json.dumps(records[0])  # a plain JSON record


# --------------------------------------------------------------------------- with the simulator
SIM_TASK = "kitchen/open_drawer"
SIM_COMBOS = ([("icrt", t) for t in TOKENIZERS] + [("act", None)]
              + [("act", t) for t in TOKENIZERS] + [("bc_transformer", None)])


def _sim_unavailable() -> str | None:
    try:
        import icil_paper.data  # noqa: F401
        import icil_paper.sim as sim
    except Exception as exc:  # noqa: BLE001 - any import failure skips the simulator tests
        return f"icil_paper.sim / icil_paper.data do not import ({type(exc).__name__}: {exc})"
    return sim.suite_unavailable("kitchen")


class _KeepOpen:
    """An env proxy whose close() is a no-op, so one env serves many evaluations."""

    def __init__(self, env):
        self._env = env

    def __getattr__(self, name):
        return getattr(self._env, name)

    def close(self):
        pass


_ENVS: dict = {}


def cached_env(task, obs="state", seed=0, **options):
    from icil_paper.sim import make_env

    key = (task, obs, tuple(sorted(options.items())))
    if key not in _ENVS:
        _ENVS[key] = make_env(task, obs=obs, seed=seed, **options)
    return _KeepOpen(_ENVS[key])


@pytest.fixture(scope="module")
def sim_data(tmp_path_factory):
    reason = _sim_unavailable()
    if reason:
        pytest.skip(f"simulator unavailable: {reason}")
    from icil_paper.data import ensure_demos, load_demos

    root = tmp_path_factory.mktemp("sim_data")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("ICIL_DATA", str(root))
        try:
            demos = load_demos(ensure_demos("smoke", SIM_TASK, "generated", progress=False))
        except Exception as exc:  # noqa: BLE001 - a simulator that cannot start skips
            pytest.skip(f"simulator could not generate demonstrations: {type(exc).__name__}: {exc}")
    yield root, demos
    for env in _ENVS.values():
        env.close()
    _ENVS.clear()


@pytest.mark.sim
@pytest.mark.parametrize("name,tokenizer", SIM_COMBOS, ids=[f"{p}+{t}" for p, t in SIM_COMBOS])
def test_smoke_combination_trains_and_rolls_out(sim_data, name, tokenizer):
    _, demos = sim_data
    preset = get_preset("smoke")
    spec = run_spec(preset, name, tokenizer, tasks=[SIM_TASK])
    result = train_policy(spec, run_dir=None, demos=demos, progress=False)
    assert result.metrics["steps"] == preset.train.steps
    assert np.isfinite(result.metrics["final_loss"])
    ev = EvalSpec(task=SIM_TASK, episodes=1, max_steps=preset.eval.max_steps)
    out = evaluate_policy(result.policy, ev, prompts=demos, env_factory=cached_env,
                          progress=False)
    (episode,) = out.per_episode
    assert 1 <= episode["steps"] <= preset.eval.max_steps
    assert out.success_rate in (0.0, 1.0)


@pytest.mark.sim
def test_smoke_mcr_on_images(sim_data):
    root, _ = sim_data
    from icil_paper.data import ensure_demos, load_demos

    with pytest.MonkeyPatch.context() as mp:  # one small-camera demonstration keeps it quick
        mp.setenv("ICIL_DATA", str(root))
        demos = load_demos(ensure_demos("smoke", SIM_TASK, "generated", n=1, obs="rgb",
                                        progress=False, camera_size=32))
    spec = run_spec(get_preset("smoke"), "mcr", tasks=[SIM_TASK])
    result = train_policy(spec, run_dir=None, demos=demos, progress=False)
    assert bool(result.policy.pretrained)
    assert not any(p.requires_grad for p in result.policy.visual.parameters())
    out = evaluate_policy(result.policy, EvalSpec(task=SIM_TASK, episodes=1, max_steps=3),
                          env_factory=cached_env, env_options={"camera_size": 32},
                          progress=False)
    assert out.per_episode[0]["steps"] <= 3


@pytest.mark.sim
def test_train_and_eval_commands_end_to_end(sim_data, tmp_path, monkeypatch):
    from icil_paper.cli import main
    from icil_paper.results import ResultsStore

    root, _ = sim_data
    monkeypatch.setenv("ICIL_DATA", str(root))  # the demonstrations generated above
    run = str(tmp_path / "run")
    assert main(["train", "--preset", "smoke", "--policy", "icrt", "--tokenizer", "lipvq",
                 "--tasks", SIM_TASK, "--run-dir", run, "--quiet"]) == 0
    assert main(["eval", "--preset", "smoke", "--run-dir", run, "--episodes", "1",
                 "--quiet"]) == 0
    (record,) = ResultsStore("smoke").records("eval")
    assert record["config"]["eval"]["task"] == SIM_TASK and record["metrics"]["episodes"] == 1


def test_evaluate_run_many_stores_what_evaluate_run_would(tmp_path, demos):
    """One call for a run's evaluations on many tasks: each record equals the one
    `evaluate_run` stores for that task alone, and is found again without computing."""
    from icil_paper.eval import evaluate_run, evaluate_run_many
    from icil_paper.results import ResultsStore
    from icil_paper.runspec import eval_spec

    preset = get_preset("smoke")
    tasks = ["synthetic/task0", "synthetic/task1"]
    run = run_spec(preset, "icrt", "lipvq", tasks=tasks)
    policy = trained("lipvq", demos)
    evs = [eval_spec(preset, t, episodes=2, max_steps=6) for t in tasks]
    store = ResultsStore("smoke")
    many = evaluate_run_many(run, evs, policy, store, "smoke", progress=False)

    def not_again():
        raise AssertionError("a stored evaluation was computed again")

    assert evaluate_run_many(run, evs, not_again, store, "smoke", progress=False) == many
    alone = ResultsStore("smoke", root=tmp_path / "alone")
    for ev, record in zip(evs, many, strict=True):
        assert evaluate_run(run, ev, not_again, store, "smoke", progress=False) == record
        single = evaluate_run(run, ev, policy, alone, "smoke", progress=False)
        assert single["config_hash"] == record["config_hash"]
        motion = ("ldlj", "sparc", "action_jerk")  # float rounding of another batch size
        strip = [{k: v for k, v in e.items() if k not in ("wall_time_s", *motion)}
                 for e in record["metrics"]["per_episode"]]
        assert strip == [{k: v for k, v in e.items() if k not in ("wall_time_s", *motion)}
                         for e in single["metrics"]["per_episode"]]
        for a, b in zip(record["metrics"]["per_episode"], single["metrics"]["per_episode"],
                        strict=True):
            assert [a[k] for k in motion] == pytest.approx([b[k] for k in motion], rel=1e-3)
