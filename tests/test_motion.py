"""Motion smoothness where the robot moves: LDLJ and SPARC of end-effector paths and the
action term match hand computations and rank a minimum-jerk reach above the same reach
with tremor; every rollout records its path and every stored evaluation carries the
numbers; tables give them per-seed estimates and the ledger decides their claims."""

from __future__ import annotations

import math

import numpy as np
import pytest

from icil_paper.config import get_preset
from icil_paper.config_data import ConfigError, to_dict
from icil_paper.metrics import (
    action_second_difference,
    log_dimensionless_jerk,
    motion_smoothness,
    sparc,
    speed_profile,
)
from icil_paper.policies.base import Policy
from icil_paper.policies.configs import ICRTConfig
from icil_paper.records import features_record
from icil_paper.results import ResultsStore
from icil_paper.runspec import EVAL_RECORD_VERSION, EvalSpec, eval_key
from icil_paper.sim.synthetic import expert_action, make_synthetic_env, task_goal
from record_helpers import write_eval_record

REACH = np.array([0.2, 0.1, -0.05])  # metres


def reach(duration=2.0, hz=20.0, tremor=0.0, tremor_hz=4.0):
    """A minimum-jerk reach along REACH sampled at `hz`, with an optional sinusoidal tremor
    of `tremor` x the reach's length along x: (T, 3) positions."""
    t = np.arange(round(duration * hz) + 1) / hz
    s = t / duration
    path = np.outer(10 * s**3 - 15 * s**4 + 6 * s**5, REACH)
    path[:, 0] += tremor * np.linalg.norm(REACH) * np.sin(2 * np.pi * tremor_hz * t)
    return path


def reference_sparc(movement, fs, padlevel=4, fc=10.0, amp_th=0.05):
    """Balasubramanian et al.'s published implementation (2015, `smoothness.py`), verbatim
    in substance: the independent computation SPARC is checked against."""
    nfft = int(pow(2, np.ceil(np.log2(len(movement))) + padlevel))
    f = np.arange(0, fs, fs / nfft)
    Mf = abs(np.fft.fft(movement, nfft))
    Mf = Mf / max(Mf)
    fc_inx = ((f <= fc) * 1).nonzero()
    f_sel, Mf_sel = f[fc_inx], Mf[fc_inx]
    inx = ((Mf_sel >= amp_th) * 1).nonzero()[0]
    fc_inx = range(inx[0], inx[-1] + 1)
    f_sel, Mf_sel = f_sel[fc_inx], Mf_sel[fc_inx]
    return -sum(np.sqrt(pow(np.diff(f_sel) / (f_sel[-1] - f_sel[0]), 2)
                        + pow(np.diff(Mf_sel), 2)))


# --------------------------------------------------------------------------- the measures
def test_a_minimum_jerk_reach_is_smoother_than_the_same_reach_with_tremor():
    dt = 1 / 20
    smooth, shaky = reach(), reach(tremor=0.02)
    assert log_dimensionless_jerk(smooth, dt) > log_dimensionless_jerk(shaky, dt) + 5
    assert sparc(speed_profile(smooth, dt), dt) > sparc(speed_profile(shaky, dt), dt) + 1
    noisy = smooth + np.random.default_rng(0).normal(0, 1e-3, smooth.shape)
    assert log_dimensionless_jerk(smooth, dt) > log_dimensionless_jerk(noisy, dt)
    assert sparc(speed_profile(smooth, dt), dt) > sparc(speed_profile(noisy, dt), dt)
    more = reach(tremor=0.05)  # more tremor, less smooth
    assert log_dimensionless_jerk(shaky, dt) > log_dimensionless_jerk(more, dt)
    assert sparc(speed_profile(shaky, dt), dt) > sparc(speed_profile(more, dt), dt)


def test_ldlj_of_a_minimum_jerk_reach_is_minus_ln_720():
    """integral |x'''|^2 = 720 A^2 / T^5 for a minimum-jerk reach: LDLJ = -ln 720 = -6.58,
    approached from below as the sampling gets finer."""
    errors = [abs(log_dimensionless_jerk(reach(hz=hz), 1 / hz) + math.log(720))
              for hz in (20, 100, 1000)]
    assert errors[0] < 0.3 and errors[1] < 0.06 and errors[2] < 0.006
    assert errors[0] > errors[1] > errors[2]  # discretisation error only
    # dimensionless: the same at another amplitude, duration (same samples) and direction
    base = log_dimensionless_jerk(reach(hz=100), 1 / 100)
    assert log_dimensionless_jerk(7 * reach(hz=100), 1 / 100) == pytest.approx(base, abs=1e-9)
    assert log_dimensionless_jerk(reach(hz=100), 3 / 100) == pytest.approx(base, abs=1e-9)
    assert log_dimensionless_jerk(reach(hz=100)[:, ::-1] + 1.0, 1 / 100) == pytest.approx(base)


def test_ldlj_matches_a_hand_computation():
    """Four points (0, 0, 0, 1) along x, dt = 1: one third difference 1, integral 1,
    duration 3, amplitude 1: LDLJ = -ln(3^5)."""
    path = np.zeros((4, 3))
    path[3, 0] = 1.0
    assert log_dimensionless_jerk(path, 1.0) == pytest.approx(-5 * math.log(3))
    # dt = 0.5: jerk 8, integral 64 * 0.5 = 32, duration 1.5: -ln(1.5^5 * 32)
    assert log_dimensionless_jerk(path, 0.5) == pytest.approx(-math.log(1.5**5 * 32))
    assert log_dimensionless_jerk(2 * path, 0.5) == pytest.approx(-math.log(1.5**5 * 32))


def test_sparc_of_a_minimum_jerk_reach_is_about_minus_1_41():
    for hz, duration in ((20, 2.0), (100, 2.0), (20, 5.0)):
        v = speed_profile(reach(duration, hz), 1 / hz)
        assert sparc(v, 1 / hz) == pytest.approx(-1.41, abs=0.015)
        assert sparc(3 * v, 1 / hz) == pytest.approx(sparc(v, 1 / hz))  # amplitude-free


def test_sparc_matches_the_published_implementation_and_a_hand_value():
    rng = np.random.default_rng(1)
    for hz, n in ((20, 60), (100, 333)):
        v = np.abs(np.convolve(rng.normal(size=n), np.ones(9) / 9, mode="same")) + 0.1
        assert sparc(v, 1 / hz) == pytest.approx(reference_sparc(v, hz), rel=1e-12)
    # one impulse: a flat spectrum, normalised magnitude 1 everywhere up to the cut-off,
    # so the arc is the frequency axis alone, of length 1
    assert sparc(np.array([0.0, 1.0, 0.0]), 1 / 20) == pytest.approx(-1.0)


def test_the_action_term_is_zero_for_linear_actions_and_matches_a_hand_value():
    t = np.arange(12.0)[:, None]
    linear = np.hstack([0.1 * t - 0.5, -0.02 * t, np.ones_like(t)])
    assert action_second_difference(linear) == pytest.approx(0.0, abs=1e-24)
    assert action_second_difference(t**2) == pytest.approx(4.0)  # second difference 2
    # (0,0) (1,0) (0,0) (1,1): second differences (-2, 0) and (2, 1): mean of 4 and 5
    hand = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 0.0], [1.0, 1.0]])
    assert action_second_difference(hand) == pytest.approx(4.5)


def test_degenerate_paths_give_nan_never_an_error():
    dt = 0.05
    for short in (np.zeros((0, 3)), np.zeros((1, 3)), reach()[:3]):
        out = motion_smoothness(short, np.zeros((max(0, len(short) - 1), 7)), dt)
        assert math.isnan(out["ldlj"]) and math.isnan(out["sparc"])
        assert math.isnan(out["action_jerk"])
    still = motion_smoothness(np.full((30, 3), 0.4), np.zeros((29, 7)), dt)
    assert math.isnan(still["ldlj"]) and math.isnan(still["sparc"])  # zero amplitude
    assert still["action_jerk"] == 0.0
    broken = reach()
    broken[5, 1] = np.nan
    assert math.isnan(log_dimensionless_jerk(broken, dt))
    assert math.isnan(sparc(speed_profile(broken, dt), dt))
    assert math.isnan(action_second_difference(np.array([[1.0], [np.inf], [0.0]])))
    line = np.outer(np.arange(10.0), [0.25, 0.0, 0.0])  # constant speed: no jerk at all
    assert log_dimensionless_jerk(line, dt) == math.inf
    with pytest.raises(ValueError, match=r"\(T, 3\)"):
        log_dimensionless_jerk(np.zeros((10, 2)), dt)
    with pytest.raises(ValueError, match="dt"):
        log_dimensionless_jerk(reach(), 0.0)


# --------------------------------------------------------------------------- rollouts
SPEC = {"proprio": 9, "object": 6}


class GoalPolicy(Policy):
    """Steers to synthetic task 0's goal (no prompt)."""

    name = "goal"
    uses_prompt = False

    def reset(self, prompt=None, instruction=None):
        self.goal = task_goal("synthetic/task0")

    def select_action(self, obs):
        return expert_action(obs["proprio"].astype(np.float64), self.goal, 7).astype(np.float32)


class StillPolicy(GoalPolicy):
    name = "still"

    def select_action(self, obs):
        return np.zeros(7, np.float32)


def evaluate(policy, episodes=4, max_steps=40, **kw):
    from icil_paper.eval import evaluate_policy

    return evaluate_policy(policy(ICRTConfig(), SPEC, 7),
                           EvalSpec(task="synthetic/task0", episodes=episodes, seed=1,
                                    max_steps=max_steps),
                           env_factory=make_synthetic_env, progress=False, **kw)


def test_a_rollout_keeps_its_end_effector_path_and_executed_actions():
    from icil_paper.eval.rollouts import rollout_policy

    env = make_synthetic_env("synthetic/task0")
    out = rollout_policy(GoalPolicy(ICRTConfig(), SPEC, 7), env, seed=3, max_steps=30,
                         keep_trace=True)
    T = out["steps"]
    assert out["eef_path"].shape == (T + 1, 3) and out["actions"].shape == (T, 7)
    acted_on = np.array([o["proprio"][:3] for o in out["obs"]] + [out["final_obs"]["proprio"][:3]])
    np.testing.assert_allclose(out["eef_path"], acted_on, atol=1e-6)
    assert out["dt"] == env.control_dt == pytest.approx(1 / 20)


def test_every_episode_carries_its_motion_smoothness():
    result = evaluate(GoalPolicy)
    for e in result.per_episode:
        assert {"ldlj", "sparc", "action_jerk"} <= set(e)
        assert "eef_path" not in e and "actions" not in e  # numbers, not paths
        if e["steps"] >= 3:
            assert all(isinstance(e[k], float) and math.isfinite(e[k])
                       for k in ("ldlj", "sparc", "action_jerk"))
        else:
            assert e["ldlj"] is None and e["sparc"] is None  # too few steps: undefined
    defined = [e["ldlj"] for e in result.per_episode if e["ldlj"] is not None]
    assert defined and result.ldlj == pytest.approx(np.mean(defined), abs=1e-6)
    from icil_paper.eval import EvalResult

    assert EvalResult.from_dict(result.to_dict()) == result
    still = evaluate(StillPolicy, episodes=2, max_steps=12)
    assert all(e["ldlj"] is None and e["sparc"] is None and e["action_jerk"] == 0.0
               for e in still.per_episode)  # it never moved: no smoothness to speak of
    assert still.ldlj is None and still.action_jerk == 0.0


def test_motion_numbers_are_the_same_on_every_run():
    """The numbers come from the path each rollout recorded: the same, bit for bit, on
    every run (the same batch size)."""
    import dataclasses

    import torch

    from icil_paper.eval import evaluate_policy
    from icil_paper.policies import make_policy
    from icil_paper.sim.synthetic import synthetic_demos

    torch.manual_seed(0)
    policy = make_policy(dataclasses.replace(get_preset("smoke").policies.bc_transformer),
                         SPEC, 7)
    policy.prepare(synthetic_demos(n_tasks=1, per_task=2, steps=20))
    ev = EvalSpec(task="synthetic/task0", episodes=4, seed=1, max_steps=15)
    one, two = (evaluate_policy(policy.eval(), ev, env_factory=make_synthetic_env,
                                progress=False, batch_size=1) for _ in range(2))
    keys = ("ldlj", "sparc", "action_jerk")
    assert [[e[k] for k in keys] for e in one.per_episode] == \
        [[e[k] for k in keys] for e in two.per_episode]
    assert all(e["ldlj"] is not None for e in one.per_episode)


def test_stored_evaluations_carry_motion_and_older_records_are_not_reused(tmp_path):
    from icil_paper.eval import evaluate_run
    from icil_paper.runspec import run_spec

    run = run_spec(get_preset("smoke"), "icrt", "mlp", tasks=["synthetic/task0"])
    ev = EvalSpec(task="synthetic/task0", episodes=2, seed=1, max_steps=20)
    store = ResultsStore("smoke", root=tmp_path)
    record = evaluate_run(run, ev, GoalPolicy(ICRTConfig(), SPEC, 7), store, "smoke",
                          progress=False)
    assert record["config_hash"] == eval_key(run, ev)
    assert record["config"]["eval"]["record_version"] == EVAL_RECORD_VERSION
    assert all({"ldlj", "sparc", "action_jerk"} <= set(e)
               for e in record["metrics"]["per_episode"])
    assert {"ldlj", "sparc", "action_jerk"} <= set(record["metrics"])
    # a record of the code before motion was measured had no record_version in its key
    old = {k: v for k, v in to_dict(ev, keyed_only=True).items() if k != "record_version"}
    from icil_paper.config_data import spec_key

    assert spec_key({"run": run, "eval": old}) != eval_key(run, ev)
    with pytest.raises(ConfigError, match="record_version"):
        EvalSpec(task="synthetic/task0", episodes=2, record_version=1)


# --------------------------------------------------------------------------- tables, claims
def small_preset(*overrides):
    return get_preset("smoke").with_overrides(
        ["data.robocasa_tasks=kitchen/open_drawer,kitchen/close_drawer,kitchen/open_door",
         *overrides])


def motion_records(preset, store, table_id, ldlj_of, success=0.5, seed=0, undefined=0.0,
                   motion=True):
    """An eval record for every unit of a table: per-episode LDLJ drawn around
    ldlj_of(row, seed index) (sd 1), SPARC around LDLJ / 5, action jerk 0.1; a share
    `undefined` of the episodes has no value; `motion` False: no motion entries at all."""
    from icil_paper.paper import table_spec

    rng = np.random.default_rng(seed)
    for row in table_spec(preset, table_id).rows:
        for entry in row.entries.values():
            for unit in entry.units:
                if unit.eval is None:
                    continue
                n = unit.eval.episodes
                per = []
                for i in range(n):
                    value = float(rng.normal(ldlj_of(row.label, unit.seed_index), 1.0))
                    gap = rng.random() < undefined
                    per.append({"episode": i, "success": bool(rng.random() < success),
                                "steps": 50})
                    if motion:
                        per[-1].update(ldlj=None if gap else value,
                                       sparc=None if gap else value / 5, action_jerk=0.1)
                write_eval_record(store, unit, per, mean_steps=50.0)


def test_a_cell_estimates_motion_with_the_seed_as_the_unit():
    from icil_paper.paper import table_spec
    from icil_paper.tables.assemble import assemble, filled_motion

    preset = small_preset("eval.episodes_per_task=20", "tables.icrt_seeds=3")
    store = ResultsStore(preset.name)
    seed_means = {0: -10.0, 1: -14.0, 2: -12.0}
    motion_records(preset, store, "V", lambda row, s: seed_means[s], undefined=0.2)
    result = assemble(table_spec(preset, "V"), store)
    cell = result.entry("icrt+lipvq", "avg")
    assert cell.motion["ldlj"].shape == (3, 4 * 20)  # seeds, episodes of the Kinova tasks
    assert np.isnan(cell.motion["ldlj"]).any()  # the undefined episodes
    est = result.motion_estimate("icrt+lipvq", "avg", "ldlj")
    per_seed = np.nanmean(cell.motion["ldlj"], axis=1)  # each seed over its defined episodes
    assert est.value == pytest.approx(per_seed.mean())
    assert est.n == 3 and "t on 3 seeds" in est.method
    assert est.low < -12 < est.high and est.high - est.low > 2  # the seeds' spread
    filled = filled_motion(cell.motion["ldlj"])
    np.testing.assert_allclose(filled.mean(axis=1), per_seed)
    one = result.motion_estimate("bc_transformer", "avg", "ldlj")  # one seed: episodes only
    assert one.n == 1 and "one seed" in one.method
    no_value = np.full((2, 5), np.nan)
    no_value[0, 1] = 1.0
    assert filled_motion(no_value) is None  # a seed with no defined episode


def test_records_without_motion_entries_leave_success_alone():
    """Records that hold no motion entries (written by hand, or by older code under its
    own key) still give success; their motion is not run, and so are its claims."""
    from icil_paper.paper import claims_ledger, table_spec
    from icil_paper.tables.assemble import assemble

    preset = small_preset("eval.episodes_per_task=10", "tables.icrt_seeds=2")
    store = ResultsStore(preset.name)
    motion_records(preset, store, "V", lambda row, s: -12.0, motion=False)
    result = assemble(table_spec(preset, "V"), store)
    assert result.estimate("icrt+lipvq") is not None and result.complete
    assert result.motion_estimate("icrt+lipvq") is None
    assert result.motion_scores("icrt+lipvq") is None
    entry = {e.id: e for e in claims_ledger(preset, store)}["V-lipvq-smoother-motion"]
    assert entry.verdict == "not run"


def test_the_motion_claims_get_verdicts():
    from icil_paper.paper import claims_ledger

    preset = small_preset("eval.episodes_per_task=20", "tables.icrt_seeds=3",
                          "tables.baseline_seeds=3")
    store = ResultsStore(preset.name)
    smooth = {"icrt+lipvq": -8.0, "icrt+bin": -14.0, "bc_transformer": -15.0}
    motion_records(preset, store, "V", lambda row, s: smooth.get(row, -12.0) + 0.3 * s)
    entry = {e.id: e for e in claims_ledger(preset, store)}["V-lipvq-smoother-motion"]
    assert entry.verdict == "holds" and entry.ours == pytest.approx(6.0, abs=0.5)
    assert entry.paper is None and entry.reference_effect is None
    assert entry.seeds == {"icrt+lipvq": 3, "bc_transformer": 3, "icrt+bin": 3}
    assert entry.mde > 0 and entry.seeds_needed is None and entry.size is None
    assert "intersection test" in entry.method

    reversed_ = small_preset("eval.episodes_per_task=20", "tables.icrt_seeds=3",
                             "tables.baseline_seeds=3", "seed=1")
    store = ResultsStore(reversed_.name)
    worse = {"icrt+lipvq": -16.0, "icrt+bin": -10.0, "bc_transformer": -9.0}
    motion_records(reversed_, store, "V", lambda row, s: worse.get(row, -12.0) + 0.3 * s)
    entry = {e.id: e for e in claims_ledger(reversed_, store)}["V-lipvq-smoother-motion"]
    assert entry.verdict == "does not hold"

    from icil_paper.tables.claims import sentence

    assert "no number" in sentence(entry)


def test_one_seed_motion_claims_are_not_decided():
    from icil_paper.paper import claims_ledger

    preset = small_preset("eval.episodes_per_task=20")  # one seed a row
    store = ResultsStore(preset.name)
    motion_records(preset, store, "V",
                   lambda row, s: {"icrt+lipvq": -5.0}.get(row, -20.0))
    entry = {e.id: e for e in claims_ledger(preset, store)}["V-lipvq-smoother-motion"]
    assert entry.verdict == entry.adjusted_verdict == "too few seeds"


def test_smoother_latents_and_smoother_motion_are_correlated_across_tokenizers():
    from icil_paper.paper import claims_ledger, table_spec
    from icil_paper.tables.definitions import TOKENIZER_ROWS

    preset = small_preset("eval.episodes_per_task=10", "tables.icrt_seeds=3")
    store = ResultsStore(preset.name)
    rank = {r: i for i, r in enumerate(TOKENIZER_ROWS)}  # mlp smoothest latents ... lipvq
    motion_records(preset, store, "I", lambda row, s: -20.0 + 2.0 * rank.get(row, 0))
    rng = np.random.default_rng(0)
    for row in table_spec(preset, "III").rows:
        for unit in row.entries["least_energy"].units:
            energy = rng.normal(10.0 - rank[row.label], 0.2, 30).tolist()  # lipvq lowest
            store.write(*features_record(unit.run, unit.features),
                        {"least_energy_per_trajectory": energy,
                         "least_energy_standardized_per_trajectory": energy,
                         "latent_scale": 1.0, "view": [[0.0, 0.0]]},
                        seed=unit.run.seed, wall_time_s=0.0)
    entry = {e.id: e for e in claims_ledger(preset, store)}[
        "III-smoother-latents-smoother-motion"]
    assert entry.ours == pytest.approx(-1.0)  # lower energy, higher LDLJ, row for row
    assert entry.verdict == "holds" and entry.source == "ours"
    assert entry.seeds == {r: 3 for r in TOKENIZER_ROWS}


def test_the_book_shows_motion_beside_success():
    from icil_paper.paper import table_spec
    from icil_paper.tables.assemble import assemble
    from icil_paper.tables.display import motion_coverage, motion_frame

    preset = small_preset("eval.episodes_per_task=10", "tables.icrt_seeds=2")
    store = ResultsStore(preset.name)
    motion_records(preset, store, "V", lambda row, s: -12.0 - 0.5 * s, undefined=0.1)
    result = assemble(table_spec(preset, "V"), store)
    frame = motion_frame(result)
    assert list(frame.index) == ["bc_transformer", "icrt+bin", "icrt+lipvq"]
    assert list(frame.columns) == ["success", "LDLJ (higher: smoother)",
                                   "SPARC (higher: smoother)", "action jerk (lower: smoother)"]
    assert frame.loc["icrt+lipvq", "LDLJ (higher: smoother)"].startswith("-12")
    assert "[" in frame.loc["icrt+lipvq", "SPARC (higher: smoother)"]
    defined, total = motion_coverage(result)["LDLJ"]
    assert 0 < defined < total
    empty = assemble(table_spec(preset, "V"), ResultsStore("nothing-here"))
    assert set(motion_frame(empty)["LDLJ (higher: smoother)"]) == {"not run"}


# --------------------------------------------------------------------------- the simulators
@pytest.mark.sim
@pytest.mark.parametrize("task", ["kitchen/open_drawer", "kinova/open_drawer",
                                  "maniskill/pick_cube"])
def test_each_suite_reads_its_end_effector_from_the_simulator(task):
    from icil_paper import sim

    reason = sim.suite_unavailable(sim.suite_of(task))
    if reason:
        pytest.skip(f"{task}: {reason}")
    env = sim.make_env(task)
    try:
        obs, _ = env.reset(seed=5)
        assert env.control_dt == pytest.approx(1 / 20)
        for _ in range(3):
            before = env.eef_position()
            obs, *_ = env.step(np.array([1.0, 0, 0, 0, 0, 0, -1.0], np.float32))
            p = env.eef_position()
            assert p.shape == (3,) and p.dtype == np.float64
            assert p[0] > before[0]  # +x moves the end effector along +x
            noise = 0.0 if not task.startswith("kinova") else 0.02  # Kinova: noisy obs
            np.testing.assert_allclose(obs["proprio"][:3], p, atol=max(noise, 1e-5))
    finally:
        env.close()
