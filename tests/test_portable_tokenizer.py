"""Exported tokenizers (`icil_paper.tokenizers.portable`): a folder of JSON and safetensors
rebuilds the same tokenizer (codes and reconstructions) in a fresh process, carries the fitted
state of every tokenizer, and a foreign or damaged folder is refused in one line."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest
import torch

from icil_paper import cli, commands
from icil_paper.config import get_preset
from icil_paper.runspec import run_spec
from icil_paper.sim.synthetic import synthetic_demos
from icil_paper.tokenizers import (
    TOKENIZERS,
    TokenizerFolderError,
    load_tokenizer,
    make_tokenizer,
    save_tokenizer,
)
from icil_paper.tokenizers.configs import FASTConfig
from icil_paper.tokenizers.portable import CONFIG_FILE, WEIGHTS_FILE, _checksum
from icil_paper.train import load_policy, train_policy

A = 7


def smooth_actions(n: int, steps: int, seed: int) -> np.ndarray:
    """(n, steps, A) random walks in [-1, 1]: actions that look like a robot's."""
    rng = np.random.default_rng(seed)
    return np.clip(np.cumsum(rng.normal(0, 0.08, (n, steps, A)), axis=1), -1, 1)


TRAIN, HELD_OUT = smooth_actions(8, 24, seed=0), smooth_actions(3, 20, seed=1)


def outputs(tokenizer, actions) -> dict[str, torch.Tensor]:
    """What a user of the tokenizer reads: codes, embeddings, reconstruction, decode."""
    with torch.no_grad():
        out = tokenizer(torch.as_tensor(actions, dtype=torch.float32))
        result = {"embeddings": out.embeddings, "reconstruction": out.reconstruction,
                  "decoded": tokenizer.decode(out.embeddings)}
        if out.codes is not None:
            result["codes"] = out.codes
    return result


def trained_like(name: str, seed: int = 0):
    """A tokenizer of `name`, fitted to TRAIN, its floating-point weights moved off their
    initial values (as training would), so that a load that lost them cannot pass."""
    torch.manual_seed(seed)
    tokenizer = make_tokenizer(name, A)
    if tokenizer.needs_fit:
        tokenizer.fit(TRAIN)
    generator = torch.Generator().manual_seed(100 + seed)
    with torch.no_grad():
        for p in tokenizer.parameters():
            p.add_(0.05 * torch.randn(p.shape, generator=generator))
    return tokenizer.eval()


def assert_same(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for key in a:
        assert torch.equal(a[key], b[key]), key


@pytest.mark.parametrize("name", TOKENIZERS)
def test_every_tokenizer_round_trips_through_a_folder(tmp_path, name):
    tokenizer = trained_like(name)
    folder = save_tokenizer(tokenizer, tmp_path / name)
    assert (folder / WEIGHTS_FILE).read_bytes()[8:9] == b"{"  # safetensors: a JSON header
    torch.manual_seed(1)  # the loaded copy starts from other random weights
    loaded = load_tokenizer(folder)
    assert type(loaded) is type(tokenizer) and loaded.config == tokenizer.config
    assert not loaded.training and loaded.fitted
    assert_same(outputs(loaded, HELD_OUT), outputs(tokenizer, HELD_OUT))
    # the same config built afresh (and fitted to other data) differs: the folder carried it
    torch.manual_seed(0)
    fresh = make_tokenizer(tokenizer.config, A)
    if fresh.needs_fit:
        fresh.fit(HELD_OUT)
    mine, theirs = outputs(tokenizer, HELD_OUT), outputs(fresh.eval(), HELD_OUT)
    assert not all(torch.equal(mine[k], theirs[k]) for k in mine)


def test_fitted_state_travels_bin_ranges_and_fast_bpe(tmp_path):
    from tokenizers import Tokenizer

    bins = trained_like("bin")
    loaded = load_tokenizer(save_tokenizer(bins, tmp_path / "bin"))
    assert torch.equal(loaded.low, bins.low) and torch.equal(loaded.high, bins.high)
    assert torch.equal(loaded.low, torch.as_tensor(TRAIN.reshape(-1, A).min(0), dtype=torch.float32))

    fast = trained_like("fast")
    folder = save_tokenizer(fast, tmp_path / "fast")
    bpe = Tokenizer.from_file(str(folder / "bpe.json"))  # the `tokenizers` package reads it
    assert bpe.get_vocab_size() == fast.bpe_vocab_size
    loaded = load_tokenizer(folder)
    assert (loaded.min_token, loaded.max_token) == (fast.min_token, fast.max_token)
    chunks = HELD_OUT[:, :fast.chunk]
    assert loaded.encode_tokens(chunks) == fast.encode_tokens(chunks)


@pytest.fixture(scope="module")
def trained_runs(tmp_path_factory):
    """Run folders of tiny ICRT policies trained with lipvq and with fast, and one of ACT
    without a tokenizer."""
    root = tmp_path_factory.mktemp("runs")
    demos = synthetic_demos(n_tasks=1, per_task=3, steps=(12, 16), seed=0)
    preset = get_preset("smoke").with_overrides(["train.steps=3"])
    runs = {}
    for policy, tokenizer in (("icrt", "lipvq"), ("icrt", "fast"), ("act", None)):
        spec = run_spec(preset, policy, tokenizer, tasks=["synthetic/task0"])
        run = root / f"{policy}-{tokenizer}"
        train_policy(spec, run_dir=run, demos=demos, progress=False)
        runs[tokenizer or policy] = run
    return runs


LOAD_IN_A_FRESH_PROCESS = """
import sys
import numpy as np, torch
torch.set_num_threads(1)
from icil_paper.tokenizers import load_tokenizer
tok = load_tokenizer(sys.argv[1])
actions = torch.as_tensor(np.load(sys.argv[2]), dtype=torch.float32)
with torch.no_grad():
    out = tok(actions)
    decoded = tok.decode(out.embeddings)
np.savez(sys.argv[3], codes=out.codes.numpy(), reconstruction=out.reconstruction.numpy(),
         embeddings=out.embeddings.numpy(), decoded=decoded.numpy())
"""


@pytest.mark.parametrize("tokenizer", ["lipvq", "fast"])
def test_exported_tokenizer_of_a_run_loads_in_a_fresh_process(tmp_path, trained_runs, tokenizer,
                                                              capsys):
    run, out = trained_runs[tokenizer], tmp_path / "exported"
    assert cli.main(["export-tokenizer", str(run), str(out)]) == 0
    assert "load_tokenizer(" in capsys.readouterr().out
    policy_tokenizer = load_policy(run).tokenizer
    config = json.loads((out / CONFIG_FILE).read_text())
    assert config["source"]["run_dir"] == run.name and config["source"]["steps"] == 3
    expected = {k: v.numpy() for k, v in outputs(policy_tokenizer, HELD_OUT).items()}

    actions, result = tmp_path / "actions.npy", tmp_path / "result.npz"
    np.save(actions, HELD_OUT)
    done = subprocess.run([sys.executable, "-c", LOAD_IN_A_FRESH_PROCESS, str(out), str(actions),
                           str(result)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    got = np.load(result)
    for key in ("codes", "reconstruction", "embeddings", "decoded"):
        assert np.array_equal(got[key], expected[key]), key
    # a second export to the same folder replaces the first
    assert cli.main(["export-tokenizer", str(run), str(out)]) == 0


def test_export_refuses_what_it_cannot_export_in_one_line(tmp_path, trained_runs, capsys):
    cases = [
        ([str(trained_runs["act"]), str(tmp_path / "a")], "has no action tokenizer"),
        ([str(tmp_path / "no_run"), str(tmp_path / "b")], "no trained policy at"),
    ]
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "notes.txt").write_text("mine")
    cases.append(([str(trained_runs["lipvq"]), str(tmp_path / "busy")], "is not empty"))
    for argv, message in cases:
        assert cli.main(["export-tokenizer", *argv]) == 2
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1, err
    assert (tmp_path / "busy" / "notes.txt").read_text() == "mine"


def _rewrite_config(folder, change):
    path = folder / CONFIG_FILE
    config = json.loads(path.read_text())
    change(config)
    path.write_text(json.dumps(config))


def _damage(kind):
    """Ways a folder goes wrong, each with the words its error must say."""
    def truncate(name, keep=0.5):
        def apply(folder):
            data = (folder / name).read_bytes()
            (folder / name).write_bytes(data[:int(len(data) * keep)])
        return apply

    def edit_field(folder):  # a hand edit that keeps the shapes: only the checksum sees it
        _rewrite_config(folder, lambda c: c["tokenizer"].update(scale=20.0))

    def other_format(folder):
        _rewrite_config(folder, lambda c: c.update(format="icil_paper.tokenizer/0"))

    def edit_bpe(folder):
        text = json.loads((folder / "bpe.json").read_text())
        text["model"]["vocab"] = dict(list(text["model"]["vocab"].items())[:-1])
        (folder / "bpe.json").write_text(json.dumps(text))

    def delete_weights(folder):
        (folder / WEIGHTS_FILE).unlink()

    def weights_of_another(folder):  # consistent hashes, wrong shapes: strict loading sees it
        other = save_tokenizer(make_tokenizer(FASTConfig(latent_dim=8), A).fit(TRAIN),
                               folder.parent / "other")
        (folder / WEIGHTS_FILE).write_bytes((other / WEIGHTS_FILE).read_bytes())
        sha = json.loads((other / CONFIG_FILE).read_text())["files"][WEIGHTS_FILE]

        def point(c):
            c["files"][WEIGHTS_FILE] = sha
            c["checksum"] = _checksum(c)
        _rewrite_config(folder, point)

    return {
        "truncated weights": (truncate(WEIGHTS_FILE), "weights.safetensors is damaged"),
        "truncated config": (truncate(CONFIG_FILE), "is damaged (not JSON"),
        "edited config": (edit_field, "does not match its checksum"),
        "other format": (other_format, "holds format 'icil_paper.tokenizer/0'"),
        "edited bpe": (edit_bpe, "bpe.json is damaged"),
        "missing weights": (delete_weights, "weights.safetensors is missing"),
        "weights of another": (weights_of_another, "its weights do not fit its config"),
    }[kind]


@pytest.mark.parametrize("kind", ["truncated weights", "truncated config", "edited config",
                                  "other format", "edited bpe", "missing weights",
                                  "weights of another"])
def test_damaged_or_foreign_folder_is_refused_in_one_line(tmp_path, kind):
    folder = save_tokenizer(trained_like("fast"), tmp_path / "fast")
    load_tokenizer(folder)  # whole, it loads
    damage, message = _damage(kind)
    damage(folder)
    with pytest.raises(TokenizerFolderError, match=re.escape(message)) as exc:
        load_tokenizer(folder)
    assert isinstance(exc.value, ValueError) and "\n" not in str(exc.value)
    assert "export" in str(exc.value)  # the fix: export it again
    assert any(isinstance(exc.value, e) for e in commands.USER_ERRORS)  # the CLI's exit 2


def test_missing_folder_and_unfitted_tokenizer(tmp_path):
    with pytest.raises(FileNotFoundError, match="no exported tokenizer at"):
        load_tokenizer(tmp_path / "nowhere")
    with pytest.raises(ValueError, match="not fitted"):
        save_tokenizer(make_tokenizer("bin", A), tmp_path / "bin")
