import dataclasses

import pytest

from icil_paper.config import (
    PRESET_NAMES,
    DataConfig,
    EvalConfig,
    PolicyConfigs,
    Preset,
    TokenizerConfigs,
    TokenizerStudyConfig,
    TrainConfig,
    active_preset_name,
    field_docs,
    get_preset,
)
from icil_paper.policies.configs import POLICY_CONFIGS
from icil_paper.registry import UnknownNameError, check_name
from icil_paper.results import config_hash
from icil_paper.seeding import seed_everything
from icil_paper.tokenizers.configs import TOKENIZER_CONFIGS, LipschitzOptions


@pytest.mark.parametrize("name", PRESET_NAMES)
def test_every_preset_builds_and_is_named(name):
    preset = get_preset(name)
    assert preset.name == name
    assert preset.train.steps > 0 and preset.eval.episodes_per_task > 0


def test_presets_grow_from_smoke_to_full():
    smoke, small, reference, full = (get_preset(n) for n in PRESET_NAMES)
    assert smoke.train.steps < small.train.steps < reference.train.steps < full.train.steps
    assert (smoke.eval.episodes_per_task <= small.eval.episodes_per_task
            < reference.eval.episodes_per_task < full.eval.episodes_per_task)
    assert small.tables.icrt_seeds < reference.tables.icrt_seeds
    assert smoke.data.demos_per_task < small.data.demos_per_task < full.data.demos_per_task
    assert (smoke.policies.icrt.d_model < small.policies.icrt.d_model
            < full.policies.icrt.d_model)


def test_preset_comes_from_environment(monkeypatch):
    monkeypatch.setenv("ICIL_PRESET", "full")
    assert active_preset_name() == "full"
    assert get_preset().name == "full"
    assert get_preset("small").name == "small"  # an explicit name wins
    monkeypatch.delenv("ICIL_PRESET")
    assert active_preset_name() == "small"


def test_unknown_preset_lists_valid_names(monkeypatch):
    with pytest.raises(UnknownNameError, match="smoke, small, reference, full"):
        get_preset("tiny")
    monkeypatch.setenv("ICIL_PRESET", "medium")
    with pytest.raises(UnknownNameError, match="unknown preset 'medium'"):
        get_preset()


def test_check_name_suggests_a_close_match():
    with pytest.raises(UnknownNameError, match="Did you mean 'lipvq'"):
        check_name("tokenizer", "lipvqq", ["mlp", "vq", "lipvq"])
    assert check_name("tokenizer", "vq", ["mlp", "vq"]) == "vq"


@pytest.mark.parametrize("cls", [DataConfig, TrainConfig,
                                 EvalConfig, TokenizerStudyConfig, Preset, LipschitzOptions,
                                 *TOKENIZER_CONFIGS.values(), *POLICY_CONFIGS.values()])
def test_every_config_field_has_a_docstring(cls):
    docs = field_docs(cls)
    missing = [f.name for f in dataclasses.fields(cls) if not docs.get(f.name)]
    assert not missing, f"{cls.__name__} fields without a docstring: {missing}"


@pytest.mark.parametrize("section", [TokenizerConfigs, PolicyConfigs])
def test_every_component_of_a_section_has_a_docstring(section):
    docs = field_docs(section)
    assert list(docs) == list(section.registered()) and all(docs.values())


def test_preset_hash_is_stable_and_sensitive():
    a, b = get_preset("small"), get_preset("small")
    assert config_hash(a.to_dict()) == config_hash(b.to_dict())
    changed = a.replace(train={"steps": a.train.steps + 1})
    assert changed.train.steps == a.train.steps + 1 and changed.policies == a.policies
    assert config_hash(changed.to_dict()) != config_hash(a.to_dict())
    assert get_preset("small", seed=3).seed == 3


def test_seed_everything_repeats_and_rejects_bad_seeds():
    import torch

    seed_everything(7)
    first = (torch.rand(3), seed_everything(7).random())
    second_torch = torch.rand(3)
    assert torch.equal(first[0], second_torch)
    assert seed_everything(7).random() == first[1]
    with pytest.raises(ValueError, match="non-negative integer"):
        seed_everything(-1)
