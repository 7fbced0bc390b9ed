"""Every check a component makes of its config in its constructor is made by the config
itself when it is built (`__post_init__`), so a bad value is refused before any data set,
run folder or training: the walk below changes each field of each registered tokenizer and
policy to values at the edges of its range and fails on any value the config accepts but
the component's constructor refuses."""

from __future__ import annotations

import dataclasses
import typing

import pytest
import torch

from icil_paper.config import get_preset
from icil_paper.config_data import _hints
from icil_paper.policies import make_policy
from icil_paper.policies.configs import POLICY_REGISTRY
from icil_paper.tokenizers import make_tokenizer
from icil_paper.tokenizers.configs import TOKENIZER_REGISTRY

ACTION_DIM = 7
OBS = {"proprio": 9, "object": 6}
INTS = (0, 1, 2, 3, 4, 5, 8, 9, 16, 33, 48, 64)
FLOATS = (0.0, 1e-6, 0.5, 1.0, 2.0)
INT_TUPLES = ((), (1,), (2,), (3,), (2, 2), (3, 3), (1, 5), (8, 5, 5, 5))


def _probes(annotation: typing.Any) -> tuple:
    args = [a for a in typing.get_args(annotation) if a is not type(None)]
    if typing.get_origin(annotation) is tuple or any(typing.get_origin(a) is tuple for a in args):
        return INT_TUPLES
    if annotation is bool or bool in args:
        return (False, True)
    if annotation is int or int in args:
        return INTS
    if annotation is float or float in args:
        return FLOATS
    return ()  # strings: their choices are checked against the components' own lists


def _variants(config: typing.Any):
    """(field path, value, changed config) for every probe of every field the config
    accepts, nested configs (Lipschitz options) included."""
    hints = _hints(type(config))
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if dataclasses.is_dataclass(value):
            for path, probe, inner in _variants(value):
                try:
                    yield f"{f.name}.{path}", probe, dataclasses.replace(config, **{f.name: inner})
                except ValueError:
                    continue
            continue
        for probe in _probes(hints.get(f.name)):
            try:
                yield f.name, probe, dataclasses.replace(config, **{f.name: probe})
            except ValueError:  # refused by the config itself: what the walk wants
                continue


def _smoke(section, name):
    return section.get(name)


@pytest.mark.parametrize("name", list(TOKENIZER_REGISTRY.configs))
def test_every_tokenizer_check_is_its_configs(name):
    base = _smoke(get_preset("smoke").tokenizers, name)
    missed = []
    for path, probe, config in _variants(base):
        try:
            make_tokenizer(config, ACTION_DIM)
        except ValueError as exc:
            missed.append(f"{name}.{path}={probe!r}: {exc}")
    assert not missed, "accepted by the config, refused by the tokenizer:\n" + "\n".join(missed)


@pytest.mark.parametrize("name", list(POLICY_REGISTRY.configs))
def test_every_policy_check_is_its_configs(name):
    torch.manual_seed(0)
    preset = get_preset("smoke")
    base = _smoke(preset.policies, name)
    obs = {**OBS, "rgb": (1, 16, 16, 3)} if name == "mcr" else OBS
    missed = []
    for path, probe, config in _variants(base):
        if path in ("d_model", "n_layer", "resnet_width", "pretrain_steps") and probe > 16:
            continue  # sizes only: big models cost seconds and check nothing more
        try:
            make_policy(config, obs, ACTION_DIM)
        except ValueError as exc:
            missed.append(f"{name}.{path}={probe!r}: {exc}")
    assert not missed, "accepted by the config, refused by the policy:\n" + "\n".join(missed)


@pytest.mark.parametrize("overrides,phrase", [
    (["--tokenizer", "fsq", "--set", "tokenizers.fsq.levels=[2,2]"],
     "FSQConfig.levels must be at least 3 each"),
    (["--tokenizer", "bspline", "--set", "tokenizers.bspline.control_points=1"],
     "BSplineConfig.control_points must be at least 4"),
    (["--tokenizer", "bspline", "--set", "tokenizers.bspline.chunk=8",
      "--set", "tokenizers.bspline.control_points=9"], "must be at most chunk (8)"),
    (["--tokenizer", "vq", "--set", "tokenizers.vq.codebook_size=1"],
     "VQConfig.codebook_size must be at least 2"),
    (["--set", "policies.icrt.query_len=0", "--set", "policies.icrt.max_seq_len=40"],
     "ICRTConfig.max_seq_len=40 is below the 48 tokens"),
])
def test_a_value_no_component_takes_is_refused_before_anything_is_written(
        tmp_path, monkeypatch, overrides, phrase):
    """Through the command line: one line, exit 2, and no data set, run folder or record
    (the sequence length once the data's episode lengths are known: here a file's)."""
    from cli_helpers import run_cli
    from test_one_writer import _kitchen_dataset

    data = _kitchen_dataset(tmp_path / "drawer.hdf5")  # episodes of 12 steps: 2*12 + 2*12 tokens
    out = {name: tmp_path / name for name in ("runs", "results")}
    monkeypatch.setenv("ICIL_RUNS", str(out["runs"]))
    monkeypatch.setenv("ICIL_RESULTS", str(out["results"]))
    code, err = run_cli("train", "--preset", "smoke", "--dataset", str(data), *overrides)
    assert code == 2 and phrase in err, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert not any(p.exists() for p in out.values()), "nothing written before the check"
