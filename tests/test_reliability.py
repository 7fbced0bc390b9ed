"""Refusing before writing, never reporting a damaged file as a result, concurrent runs.

- one writer per run folder and per record: two `icil-paper train` runs of one spec write
  one metrics line per step, and a record is computed once however many ask for it;
- a stored `train` record is reported only with the policy file it names (its SHA-256, or
  for an older record its weights' digest); a changed or missing file is set aside and
  recomputed, bit for bit;
- every file a command reads (policy, checkpoint, config.json, metrics, records) fails
  with one line naming it and the fix, whatever the damage;
- the whole spec (every config's values, task lists, a data set's widths, the output
  folders, the executor options) is checked before any data set, run folder or record is
  written.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest
import torch

from cli_helpers import run_cli
from icil_paper.config import get_preset
from icil_paper.fileio import LockedError, exclusive_lock, file_sha256
from icil_paper.records import train_record_name
from icil_paper.results import ResultsStore
from icil_paper.runspec import run_spec
from icil_paper.sim.synthetic import synthetic_demos
from icil_paper.train import (
    CONFIG_FILE,
    METRICS_FILE,
    POLICY_FILE,
    PolicyFileError,
    load_policy,
    policy_digest,
    read_metrics,
    train_policy,
)
from icil_paper.train.rundir import (
    CHECKPOINT,
    PREVIOUS_CHECKPOINT,
    DamagedFileWarning,
    load_checkpoint,
)
from icil_paper.train.stored import StaleRecordWarning, train_run

TASKS = ["synthetic/task0", "synthetic/task1"]


@pytest.fixture(scope="module")
def demos():
    return synthetic_demos(n_tasks=2, per_task=3, steps=(10, 14), seed=0)


def spec(overrides=(), policy="icrt", tokenizer="mlp"):
    preset = get_preset("smoke").with_overrides(list(overrides))
    return run_spec(preset, policy, tokenizer, tasks=TASKS)


def one_line_error(code, err, *phrases):
    assert code == 2, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    for phrase in phrases:
        assert phrase in err, err


def write_dataset(path, action_width=3, state=(9, 6), task=None, n=3, seed=0):
    """A small robomimic-layout file; `task` names a task of this library in its attrs."""
    rng = np.random.default_rng(seed)
    with h5py.File(path, "w") as f:
        data = f.create_group("data")
        if task:
            data.attrs["task"] = task
        for i in range(n):
            T = 12 + i
            g = data.create_group(f"demo_{i}")
            g.attrs["num_samples"] = T
            g["actions"] = rng.uniform(-1, 1, (T, action_width)).astype(np.float32)
            g["obs/proprio"] = rng.normal(size=(T, state[0])).astype(np.float32)
            g["obs/object"] = rng.normal(size=(T, state[1])).astype(np.float32)
    return path


def nothing_written(folders):
    return not any(p.exists() for p in folders.values())


# --------------------------------------------------------------------------- one writer
def test_two_train_runs_of_one_spec_write_one_metrics_line_per_step(tmp_path):
    """Two `icil-paper train` of the same spec started at once: both exit 0 with the same
    result, the run is trained once (one metrics line per step, in the record too)."""
    path = write_dataset(tmp_path / "reach.hdf5")
    env = {**os.environ, "ICIL_RUNS": str(tmp_path / "runs"),
           "ICIL_RESULTS": str(tmp_path / "results"), "ICIL_DATA": str(tmp_path / "data")}
    steps = 300  # seconds of training each: the two overlap whatever their start-up times
    cmd = [sys.executable, "-m", "icil_paper.cli", "train", "--preset", "smoke", "--dataset",
           str(path), "--set", f"train.steps={steps}", "--quiet"]
    procs = [subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True) for _ in range(2)]
    outs = [p.communicate(timeout=600) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outs
    assert outs[0][0] == outs[1][0]  # the same policy, the same run key
    (run_dir,) = (tmp_path / "runs" / "smoke").iterdir()
    assert [x["step"] for x in read_metrics(run_dir / METRICS_FILE)] == list(range(1, steps + 1))
    (record,) = ResultsStore("smoke", tmp_path / "results").records("train")
    assert record["metrics"]["loss_steps"] == list(range(1, steps + 1))
    assert record["files"][POLICY_FILE] == file_sha256(run_dir / POLICY_FILE)
    assert not (run_dir / ".lock").exists(), "the lock file is removed with the lock"


def test_a_record_is_computed_once_however_many_ask(tmp_path):
    store = ResultsStore("smoke", tmp_path)
    calls = []

    def compute():
        calls.append(1)
        time.sleep(0.3)
        return {"x": 1.0}

    threads = [threading.Thread(target=store.run, args=("probe", "one", {"a": 1}, compute))
               for _ in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(calls) == 1
    (record,) = store.records("probe")
    assert [p.name for p in (tmp_path / "smoke" / "probe").iterdir()] == \
        [store.path_for("probe", "one", record["config_hash"]).name], "no lock file is left"


def test_a_held_lock_is_named_and_released_with_its_holder(tmp_path):
    lock = tmp_path / "folder" / ".lock"
    probe = [sys.executable, "-c", "import sys; from icil_paper.fileio import exclusive_lock\n"
             "with exclusive_lock(sys.argv[1], what='the probe', wait=False): print('got it')",
             str(lock)]
    with exclusive_lock(lock, what="the probe"):
        with exclusive_lock(lock):  # the holder may take it again
            pass
        assert lock.exists()
        held = subprocess.run(probe, capture_output=True, text=True, timeout=120)
        assert held.returncode != 0 and f"in use by pid {os.getpid()}" in held.stderr
    assert not lock.exists()
    assert subprocess.run(probe, capture_output=True, text=True, timeout=120).stdout == "got it\n"
    found = []

    def try_lock():
        try:
            with exclusive_lock(lock, wait=False):
                found.append(None)
        except LockedError as exc:
            found.append(exc)

    with exclusive_lock(lock):  # another thread of this process is refused alike
        thread = threading.Thread(target=try_lock)
        thread.start()
        thread.join()
    assert isinstance(found[0], LockedError)


# --------------------------------------------------------------------------- stored results
def _payload_policy(path, flag):
    class Payload:
        def __reduce__(self):
            return (os.system, (f"touch {flag}",))

    torch.save({"format": "icil_paper.policy/2", "spec": Payload()}, path)


@pytest.mark.parametrize("damage", ["pickle", "other_run", "truncated", "missing"])
def test_a_changed_policy_file_is_never_reported_as_the_trained_policy(tmp_path, demos, damage):
    s = spec(["train.steps=4", "train.ckpt_every=2"])
    store = ResultsStore("smoke", tmp_path / "results")
    run_dir = tmp_path / "run"
    first = train_run(s, "smoke", store, run_dir=run_dir, demos=demos, progress=False)
    policy = run_dir / POLICY_FILE
    written = file_sha256(policy)
    assert first["files"] == {POLICY_FILE: written}
    flag = tmp_path / "pwned"
    if damage == "pickle":
        _payload_policy(policy, flag)
    elif damage == "other_run":
        other = train_policy(spec(["train.steps=3"]), run_dir=tmp_path / "other", demos=demos,
                             progress=False)
        shutil.copy(other.run_dir / POLICY_FILE, policy)
    elif damage == "truncated":
        policy.write_bytes(policy.read_bytes()[: policy.stat().st_size // 2])
    else:
        policy.unlink()
    with pytest.warns(UserWarning) as caught:
        again = train_run(s, "smoke", store, run_dir=run_dir, demos=demos, progress=False)
    categories = [w.category for w in caught]
    assert StaleRecordWarning in categories and POLICY_FILE in str(caught[-1].message)
    assert categories.count(DamagedFileWarning) == (damage != "missing"), \
        "a changed file is named as it is moved aside"
    assert not flag.exists(), "a pickle in a policy file was executed"
    assert file_sha256(policy) == written == again["files"][POLICY_FILE]  # bit for bit
    assert policy_digest(load_policy(run_dir)) == first["metrics"]["policy_digest"]
    assert [x["step"] for x in read_metrics(run_dir / METRICS_FILE)] == [1, 2, 3, 4]
    kept = list(run_dir.glob(f"{POLICY_FILE}.corrupt-*"))
    assert len(kept) == (0 if damage == "missing" else 1), "the changed file is kept"


def test_train_command_recomputes_a_policy_file_replaced_by_hand(tmp_path, folders):
    path = write_dataset(tmp_path / "reach.hdf5")
    args = ["train", "--preset", "smoke", "--dataset", str(path), "--quiet"]
    assert run_cli(*args)[0] == 0
    (run_dir,) = (folders["runs"] / "smoke").iterdir()
    written = file_sha256(run_dir / POLICY_FILE)
    _payload_policy(run_dir / POLICY_FILE, tmp_path / "pwned")
    with pytest.warns(DamagedFileWarning), pytest.warns(StaleRecordWarning):
        assert run_cli(*args)[0] == 0
    assert file_sha256(run_dir / POLICY_FILE) == written
    assert not (tmp_path / "pwned").exists()


def test_an_old_record_without_digests_is_verified_by_loading(tmp_path, demos):
    """Records written before they named their files: accepted when the policy file loads
    with the record's weights, recomputed when it does not."""
    s = spec(["train.steps=3"])
    store = ResultsStore("smoke", tmp_path / "results")
    run_dir = tmp_path / "run"
    first = train_run(s, "smoke", store, run_dir=run_dir, demos=demos, progress=False)
    path = store.path_for("train", train_record_name(s), first["config_hash"])
    old = {k: v for k, v in json.loads(path.read_text()).items() if k != "files"}
    path.write_text(json.dumps(old))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert train_run(s, "smoke", store, run_dir=run_dir, demos=demos,
                         progress=False) == old
    other = train_policy(spec(["train.steps=2"]), run_dir=tmp_path / "other", demos=demos,
                         progress=False)
    shutil.copy(other.run_dir / POLICY_FILE, run_dir / POLICY_FILE)  # loads, other weights
    with pytest.warns(DamagedFileWarning), pytest.warns(StaleRecordWarning, match="other weights"):
        again = train_run(s, "smoke", store, run_dir=run_dir, demos=demos, progress=False)
    assert again["files"] and again["metrics"]["policy_digest"] == first["metrics"]["policy_digest"]


# --------------------------------------------------------------------------- reading files
@pytest.fixture(scope="module")
def trained_dir(tmp_path_factory):
    demos = synthetic_demos(n_tasks=2, per_task=3, steps=(10, 14), seed=0)
    run_dir = tmp_path_factory.mktemp("trained") / "run"
    train_policy(spec(["train.steps=4", "train.ckpt_every=2"]), run_dir=run_dir, demos=demos,
                 progress=False)
    return run_dir


def test_every_truncation_of_a_policy_file_is_a_one_line_error(trained_dir, tmp_path):
    """Cut anywhere, a policy file is refused as damaged (some cuts make torch's zip reader
    raise OSError EINVAL, which used to escape as a traceback)."""
    data = (trained_dir / POLICY_FILE).read_bytes()
    cut = tmp_path / POLICY_FILE
    stride = max(1, len(data) // 400)
    for n in range(0, len(data), stride):
        cut.write_bytes(data[:n])
        with pytest.raises(PolicyFileError, match="damaged or not"):
            load_policy(cut)


def test_every_truncation_of_a_checkpoint_falls_back(trained_dir, tmp_path):
    key = json.loads((trained_dir / CONFIG_FILE).read_text())["key"]
    data = (trained_dir / CHECKPOINT).read_bytes()
    stride = max(1, len(data) // 60)
    for n in range(0, len(data), stride):
        shutil.copy(trained_dir / PREVIOUS_CHECKPOINT, tmp_path / PREVIOUS_CHECKPOINT)
        (tmp_path / CHECKPOINT).write_bytes(data[:n])
        with pytest.warns(UserWarning, match="damaged file"):
            ckpt = load_checkpoint(tmp_path, key)
        assert ckpt["step"] == 2, "the previous checkpoint is used"


def test_eval_on_a_truncated_policy_is_one_line_naming_the_file(trained_dir, tmp_path, folders):
    run_dir = tmp_path / "run"
    shutil.copytree(trained_dir, run_dir)
    data = (run_dir / POLICY_FILE).read_bytes()
    for n in (0, len(data) // 3, len(data) - 1):
        (run_dir / POLICY_FILE).write_bytes(data[:n])
        code, err = run_cli("eval", "--preset", "smoke", "--run-dir", str(run_dir))
        one_line_error(code, err, str(run_dir / POLICY_FILE), "retrain it")
    assert nothing_written(folders)


@pytest.mark.parametrize("config,phrase", [
    (b"\xff\xfe\x00 not text", "UnicodeDecodeError"),
    (b'{"key": "0123"}', "no 'spec'"),
    (b'[1, 2]', "not an object"),
    (b'{"key": "0", "spec": {"data": {"tasks": []}}}', "DataSpec.tasks needs at least one"),
    (None, "is a folder"),
])
def test_eval_on_a_damaged_run_config_is_one_line_naming_it(tmp_path, folders, config, phrase):
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    if config is None:
        (run_dir / CONFIG_FILE).mkdir()
    else:
        (run_dir / CONFIG_FILE).write_bytes(config)
    code, err = run_cli("eval", "--preset", "smoke", "--run-dir", str(run_dir))
    one_line_error(code, err, str(run_dir / CONFIG_FILE), phrase, "icil-paper train --run-dir")


def test_damaged_metric_lines_are_dropped_and_the_run_resumes(tmp_path, demos):
    s = spec(["train.steps=4", "train.ckpt_every=2"])
    train_policy(s, run_dir=tmp_path, demos=demos, progress=False, stop_after=2)
    with open(tmp_path / METRICS_FILE, "ab") as f:
        f.write(b"\xff\xfe\x00\x01 torn\n[3]\n")
    assert [x["step"] for x in read_metrics(tmp_path / METRICS_FILE)] == [1, 2]
    train_policy(s, run_dir=tmp_path, demos=demos, progress=False)
    assert [x["step"] for x in read_metrics(tmp_path / METRICS_FILE)] == [1, 2, 3, 4]


# --------------------------------------------------------------------------- validate first
@pytest.mark.parametrize("argv,phrase", [
    (["train", "--tokenizer", "lipvq", "--set", "tokenizers.lipvq.norm=lïpschitz"],
     "Did you mean 'lipschitz'"),
    (["train", "--set", "data.robocasa_tasks=[]"], "DataConfig.robocasa_tasks needs at least one"),
    (["train", "--set", "data.obs="], "DataConfig.obs needs a value (one of state, rgb, rgbd)"),
    (["train", "--set", "data.sources=humann"], "Did you mean 'human'"),
    (["train", "--set", "data.robocasa_tasks=kitchen/open_drawr"],
     "Did you mean 'kitchen/open_drawer'"),
    (["reproduce", "--set", "data.maniskill_tasks=kitchen/open_drawer"],
     "unknown data.maniskill_tasks task"),
    (["train", "--set", "policies.icrt.n_head=3"], "must be a multiple of n_head (3)"),
    (["train", "--set", "policies.icrt.query_start=middle"], "episode_start"),
    (["train", "--tokenizer", "lfq", "--set", "tokenizers.lfq.codebook_size=100"],
     "power of two"),
    (["train", "--set", "tokenizers.lip_mlp.lipschitz.weight_init=rand"], "Did you mean 'randn'"),
    (["train", "--set", "tokenizers.vq.straight_through="], "got an empty string"),
    (["reproduce", "--set", "tokenizer_study.trajectories=recorded"], "demos, synthetic"),
    (["reproduce", "--set", "tables.codebook_sizes=[]"], "needs at least one value"),
    (["eval", "--set", "train.betas=0.9,1"], "fraction and must be below 1"),
    (["train", "--source", "humann"], "Did you mean 'human'"),
    (["reproduce", "--executor", "ray", "--ray-address", ""], "--ray-address is empty"),
    (["reproduce", "--executor", "ray", "--ray-address", "  "], "--ray-address is empty"),
    (["reproduce", "--ray-address", "127.0.0.1:6379"], "add --executor ray"),
])
def test_a_bad_spec_is_refused_before_anything_is_written(folders, argv, phrase):
    code, err = run_cli(*argv, "--preset", "smoke")
    one_line_error(code, err, phrase)
    assert nothing_written(folders), "no data set, run folder or record before the check"


@pytest.mark.parametrize("build,phrase", [
    (lambda c: c.VQConfig(norm="lipschitz-first"), "Did you mean 'lipschitz-last'"),
    (lambda c: c.LipVQConfig(codebook_init=""), "LipVQConfig.codebook_init needs a value"),
    (lambda c: c.LFQConfig(codebook_size=48), "power of two"),
    (lambda c: c.FASTConfig(mode="sliding"), "causal, blocked"),
    (lambda c: c.MLPConfig(latent_dim=0), "MLPConfig.latent_dim counts something"),
    (lambda c: c.LipschitzOptions(c_init=0.0), "LipschitzOptions.c_init must be above 0"),
    (lambda c: c.ICRTConfig(d_model=30, n_head=4), "must be a multiple of n_head (4)"),
    (lambda c: c.ACTConfig(dropout=1.0), "ACTConfig.dropout is a fraction"),
    (lambda c: c.DataConfig(obs="depth"), "state, rgb, rgbd"),
    (lambda c: c.DataConfig(robocasa_tasks=("",)), "DataConfig.robocasa_tasks needs a value"),
    (lambda c: c.TrainConfig(betas=(0.9, 1.5)), "TrainConfig.betas is a fraction"),
    (lambda c: c.EvalConfig(episodes_per_task=0), "EvalConfig.episodes_per_task counts"),
    (lambda c: c.TablesConfig(codebook_sizes=()), "TablesConfig.codebook_sizes needs"),
    (lambda c: c.DataSpec(tasks=()), "DataSpec.tasks needs at least one value"),
    (lambda c: c.DataSpec(tasks=("kitchen/open_drawer",), source="teleop"), "file"),
    (lambda c: c.EvalSpec(task="kitchen/open_drawer", episodes=0), "EvalSpec.episodes counts"),
    (lambda c: c.EvalSpec(task="kitchen/open_drawer", episodes=1, prompt_source="x"),
     "generated, human"),
])
def test_every_config_checks_its_own_values_when_built(build, phrase):
    """Not only through --set: a config built in code with a value no component can use
    fails at once (ConfigError or UnknownNameError, both ValueErrors), naming the field."""
    import types

    from icil_paper import config, runspec
    from icil_paper.policies import configs as policy_configs
    from icil_paper.tokenizers import configs as tokenizer_configs

    c = types.SimpleNamespace(**{**vars(tokenizer_configs), **vars(policy_configs),
                                 **vars(config), **vars(runspec)})
    with pytest.raises(ValueError, match=phrase.replace("(", r"\(").replace(")", r"\)")):
        build(c)


def test_the_configs_choices_are_the_components_own():
    """The valid strings a config checks are the ones its component accepts."""
    from icil_paper import sim
    from icil_paper.config import DEMO_SOURCES, OBS_KINDS
    from icil_paper.config_data import field_choices
    from icil_paper.data.sources import SOURCES
    from icil_paper.policies import batching
    from icil_paper.policies.configs import ICRTConfig
    from icil_paper.tokenizers import base, make_tokenizer
    from icil_paper.tokenizers.configs import FASTConfig, LipschitzOptions, VQConfig

    choices = field_choices(VQConfig)
    assert choices["norm"] == base.ENCODER_NORMS
    assert choices["activation"] == tuple(base._ACTIVATIONS)
    assert choices["output_activation"] == tuple(base._OUTPUT_ACTIVATIONS)
    actions = torch.as_tensor(np.random.default_rng(0).uniform(-1, 1, (2, 6, 3)), dtype=torch.float32)
    for st in choices["straight_through"]:
        for init in choices["codebook_init"]:  # each choice is a branch of vq's
            tok = make_tokenizer(VQConfig(latent_dim=4, codebook_size=8, straight_through=st,
                                          codebook_init=init), 3).train()
            assert tok(actions).embeddings.shape == (2, 6, 4)
    for mode in choices["mode"]:
        tok = make_tokenizer(FASTConfig(latent_dim=4, vocab_size=300, chunk=2, mode=mode), 3)
        assert tok.fit(actions.numpy())(actions).embeddings.shape == (2, 6, 4)
    assert OBS_KINDS == sim.OBS_KINDS and DEMO_SOURCES == SOURCES
    for query_start in field_choices(ICRTConfig)["query_start"]:  # the batcher takes each
        batching.prompt_query_batch(batching.DemoSet(synthetic_demos(1, 2, 6)), 1, 4, 1, 1,
                                    np.random.default_rng(0), query_start=query_start)
    for weight_init in field_choices(LipschitzOptions)["weight_init"]:
        from icil_paper.tokenizers.lipschitz_linear import LipschitzLinear

        LipschitzLinear(3, 2, weight_init=weight_init)


def test_every_preset_and_table_passes_the_checks():
    """The checks accept every value the library itself uses (presets, table cells, the
    analysis variants, `whole-episode queries` included) and change no key (the committed
    reference records stay current: tests/test_tables.py)."""
    from icil_paper.config import PRESET_NAMES
    from icil_paper.paper import TABLES, table_spec

    units = 0
    for name in PRESET_NAMES:
        preset = get_preset(name)
        for table in TABLES:
            units += len(list(table_spec(preset, table).units()))
    assert units > 100


def test_query_len_0_trains_on_whole_episodes_as_documented(demos):
    s = spec(["policies.icrt.query_len=0"])
    assert s.policy.query_len == 0
    result = train_policy(s, run_dir=None, demos=demos, progress=False)
    model = result.policy
    data = model.prepare(demos, pretrain=False)
    batch = model.sample_batch(data, 16, np.random.default_rng(0))
    lengths = batch["query_valid"].sum(1).tolist()
    for b, n in enumerate(lengths):  # each query is one whole demonstration from step 0
        assert any(len(a) == n and np.array_equal(batch["query_actions"][b, :n].numpy(), a)
                   for a in data.actions), b


def test_a_data_set_of_another_width_than_its_task_is_refused_before_training(tmp_path,
                                                                               folders):
    six = write_dataset(tmp_path / "six.hdf5", action_width=6, state=(9, 18),
                        task="kitchen/open_drawer")
    code, err = run_cli("train", "--preset", "smoke", "--dataset", str(six))
    one_line_error(code, err, "6-dimensional actions", "kitchen/open_drawer takes 7")
    narrow = write_dataset(tmp_path / "narrow.hdf5", action_width=7, state=(9, 6),
                           task="kitchen/open_drawer")
    code, err = run_cli("train", "--preset", "smoke", "--dataset", str(narrow))
    one_line_error(code, err, "15-dimensional state", "gives 27")
    assert nothing_written(folders)


def _run_with_read_only(folder: Path, cmd: list[str], env: dict) -> subprocess.CompletedProcess:
    """Run `cmd` with `folder` read-only: by its mode for a user; for root, whom modes do
    not stop, by a read-only bind mount in a private mount namespace (gone with `cmd`)."""
    run = dict(env=env, capture_output=True, text=True, timeout=300)
    if os.geteuid() != 0:
        folder.chmod(0o555)
        try:
            return subprocess.run(cmd, **run)
        finally:
            folder.chmod(0o755)
    script = 'mount --bind "$1" "$1" && mount -o remount,bind,ro "$1" && shift && exec "$@"'
    wrap = ["unshare", "-m", "sh", "-c", script, "sh", str(folder)]
    if shutil.which("unshare") is None or subprocess.run(
            [*wrap, "true"], capture_output=True).returncode != 0:
        pytest.skip("no read-only folder for root here (needs unshare -m and mount)")
    return subprocess.run([*wrap, *cmd], **run)


def test_a_read_only_results_folder_is_refused_before_training(tmp_path):
    from icil_paper.config_data import to_dict
    from icil_paper.paper import table_spec
    from icil_paper.records import eval_record_name
    from icil_paper.results import config_hash

    path = write_dataset(tmp_path / "reach.hdf5")
    results = tmp_path / "results"
    unit = next(u for u in table_spec(get_preset("smoke"), "IV").units() if u.eval is not None)
    torn = ResultsStore("smoke", results).path_for(
        "eval", eval_record_name(unit.run, unit.eval),
        config_hash({"run": to_dict(unit.run, keyed_only=True),
                     "eval": to_dict(unit.eval, keyed_only=True)}))
    torn.parent.mkdir(parents=True)
    torn.write_text("{torn")  # a record table IV reads
    env = {**os.environ, "ICIL_RESULTS": str(results), "ICIL_RUNS": str(tmp_path / "runs"),
           "ICIL_DATA": str(tmp_path / "data")}
    icil = [sys.executable, "-m", "icil_paper.cli"]
    out = _run_with_read_only(results, [*icil, "train", "--preset", "smoke", "--dataset",
                                        str(path)], env)
    one_line_error(out.returncode, out.stderr, f"$ICIL_RESULTS={results}", "cannot write")
    assert not (tmp_path / "runs").exists(), "nothing is trained before the check"
    # reading needs no writing: the tables print, skipping the record they cannot set aside
    out = _run_with_read_only(results, [*icil, "tables", "--preset", "smoke", "--table", "IV"],
                              env)
    assert out.returncode == 0 and "Table IV" in out.stdout, out.stderr
    assert "could not be moved aside" in out.stderr and torn.exists()


def test_an_output_folder_under_a_file_is_named(tmp_path, monkeypatch):
    from icil_paper.fileio import check_env_folder

    (tmp_path / "file").write_text("")
    monkeypatch.setenv("ICIL_RESULTS", str(tmp_path / "file" / "results"))
    with pytest.raises(NotADirectoryError, match=r"\$ICIL_RESULTS=.*is a file"):
        check_env_folder("ICIL_RESULTS", "results")
    code, err = run_cli("train", "--preset", "smoke", "--tasks", "kitchen/open_drawer")
    one_line_error(code, err, "$ICIL_RESULTS=", "is a file")
