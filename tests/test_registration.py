"""One registration per component: a tokenizer written as one module of its own (class +
config, one decorator) is a registry name, a preset section, a `--set` path and a CLI
choice, and trains end to end, with no other file edited."""

from __future__ import annotations

import importlib
import json
import sys
import textwrap

import pytest

TOY_MODULE = '''
"""A toy tokenizer: a linear embedding times `scale`, a linear decoder."""

from dataclasses import dataclass

import torch.nn.functional as F
from torch import nn

from icil_paper.tokenizers import ActionTokenizer, TokenizerConfig, TokenizerOutput
from icil_paper.tokenizers import register_tokenizer


@register_tokenizer("toy", "ToyTokenizer")
@dataclass(frozen=True)
class ToyConfig(TokenizerConfig):
    """`toy`: one linear layer, scaled."""

    scale: float = 1.0
    """Factor of the embedding."""


class ToyTokenizer(ActionTokenizer):
    name = "toy"

    def __init__(self, config, action_dim):
        super().__init__(config, action_dim)
        self.scale = config.scale
        self.encoder = nn.Linear(action_dim, config.latent_dim)
        self.decoder = nn.Linear(config.latent_dim, action_dim)

    def _forward(self, actions):
        z = self.scale * self.encoder(actions)  # (B, T, D)
        recon = self.decoder(z.detach())
        return TokenizerOutput(embeddings=z, reconstruction=recon, codes=None,
                               losses={"reconstruction": F.mse_loss(recon, actions)}, latents=z)
'''


@pytest.fixture
def toy_module(tmp_path, monkeypatch):
    from icil_paper.tokenizers.configs import TOKENIZER_REGISTRY

    (tmp_path / "toy_tokenizer_mod.py").write_text(textwrap.dedent(TOY_MODULE))
    monkeypatch.syspath_prepend(str(tmp_path))
    module = importlib.import_module("toy_tokenizer_mod")
    yield module
    # leave the registry as the other tests expect it
    TOKENIZER_REGISTRY.forget(["toy"])
    sys.modules.pop("toy_tokenizer_mod", None)


def test_builtin_registrations_are_the_registry_the_configs_and_the_sections():
    from icil_paper.config import get_preset
    from icil_paper.policies import REGISTRY as POLICIES
    from icil_paper.policies.configs import POLICY_CONFIGS
    from icil_paper.tokenizers import REGISTRY, TOKENIZERS
    from icil_paper.tokenizers.configs import TOKENIZER_CONFIGS

    preset = get_preset("smoke")
    assert list(REGISTRY) == list(TOKENIZER_CONFIGS) == list(TOKENIZERS)
    assert list(POLICIES) == list(POLICY_CONFIGS)
    for name, config in TOKENIZER_CONFIGS.items():
        assert config.type == name and type(preset.tokenizers.get(name)) is config
        assert REGISTRY[name].__module__.startswith("icil_paper.tokenizers.")
    for name, config in POLICY_CONFIGS.items():
        assert config.type == name and type(preset.policies.get(name)) is config
        assert POLICIES[name].__module__.startswith("icil_paper.policies.")


def test_a_second_registration_of_a_name_is_refused():
    from dataclasses import dataclass

    from icil_paper.tokenizers import TokenizerConfig, register_tokenizer

    with pytest.raises(ValueError, match="'vq' is registered twice"):
        @register_tokenizer("vq", "Nothing")
        @dataclass(frozen=True)
        class OtherVQ(TokenizerConfig):
            pass
    with pytest.raises(TypeError, match="subclass of TokenizerConfig"):
        register_tokenizer("plain")(dict)


def test_a_tokenizer_of_one_module_gets_a_section_a_set_path_and_the_shared_sizes(toy_module):
    from icil_paper.config import get_preset
    from icil_paper.config_data import field_docs
    from icil_paper.policies import make_policy
    from icil_paper.tokenizers import REGISTRY, make_tokenizer

    smoke = get_preset("smoke")
    assert smoke.tokenizers.toy == toy_module.ToyConfig(latent_dim=smoke.tokenizers.vq.latent_dim)
    assert field_docs(type(smoke.tokenizers))["toy"].startswith("`toy`")
    changed = smoke.with_overrides(["tokenizers.toy.scale=2.5"])
    assert changed.tokenizers.toy.scale == 2.5 and changed.tokenizers.vq == smoke.tokenizers.vq
    assert REGISTRY["toy"] is toy_module.ToyTokenizer
    tok = make_tokenizer(changed.tokenizers.toy, 7)
    assert isinstance(tok, toy_module.ToyTokenizer) and tok.scale == 2.5
    policy = make_policy(smoke.policies.icrt, 19, 7, changed.tokenizers.toy)
    assert policy.tokenizer_config.type == "toy"
    from icil_paper.config import Preset
    from icil_paper.config_data import from_dict

    assert from_dict(Preset, changed.to_dict()) == changed  # a stored preset reads back


def test_a_tokenizer_of_one_module_trains_end_to_end_from_the_command_line(
        toy_module, tmp_path, monkeypatch, capsys):
    from icil_paper import cli
    from icil_paper.train.rundir import CONFIG_FILE

    monkeypatch.setenv("ICIL_RUNS", str(tmp_path / "runs"))
    run_dir = tmp_path / "run"
    code = cli.main(["train", "--preset", "smoke", "--tokenizer", "toy", "--tasks",
                     "kitchen/open_drawer", "--set", "tokenizers.toy.scale=0.5",
                     "--set", "train.steps=2", "--run-dir", str(run_dir), "--quiet"])
    assert code == 0
    out = capsys.readouterr().out
    assert "icrt+toy trained for 2 steps" in out
    config = json.loads((run_dir / CONFIG_FILE).read_text())
    text = json.dumps(config)
    assert '"type": "toy"' in text and '"scale": 0.5' in text
    assert cli.main(["train", "--preset", "smoke", "--tokenizer", "toy",
                     "--set", "tokenizers.toy.scale=-1"]) == 2  # checked like a built-in's
    assert "tokenizers.toy.scale must be a finite number >= 0" in capsys.readouterr().err


def test_a_config_without_a_model_class_says_how_to_register_one():
    from dataclasses import dataclass

    from icil_paper.tokenizers import REGISTRY, TokenizerConfig, register_tokenizer

    @register_tokenizer("modelless")
    @dataclass(frozen=True)
    class Modelless(TokenizerConfig):
        pass

    try:
        with pytest.raises(LookupError, match=r"@register_tokenizer_model\('modelless'\)"):
            REGISTRY["modelless"]
    finally:
        REGISTRY.forget(["modelless"])
    assert "modelless" not in REGISTRY
