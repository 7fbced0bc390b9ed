"""Run specs and their keys: every field of every config reaches the key of every stage that
reads it (and no other), `--set` overrides are typed and checked, configs round-trip."""

from __future__ import annotations

import dataclasses
import types
import typing
from collections.abc import Mapping

import pytest

from icil_paper.book.studies import study_spec
from icil_paper.config import get_preset
from icil_paper.config_data import (
    NOT_KEYED,
    OverrideError,
    from_dict,
    get_path,
    keyed_paths,
    replace_path,
    spec_key,
    to_dict,
)
from icil_paper.paper import table_spec
from icil_paper.runspec import eval_key, eval_spec, run_spec
from icil_paper.tokenizers import TOKENIZERS
from icil_paper.tokenizers.configs import TokenizerConfig

TASKS = ("metaworld/drawer-open", "metaworld/door-close")


def _other_values(annotation, value, choices=None):
    """Different values of the declared type (to perturb one field), the likeliest first;
    `choices`, a string field's valid values, give the other valid strings."""
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin in (typing.Union, types.UnionType):
        if value is None:
            yield from _other_values(next(a for a in args if a is not type(None)), None, choices)
        else:
            yield None
        return
    if annotation is bool:
        yield not value
    elif annotation is int:  # from None, a value no preset's default field happens to hold
        yield from ([7] if value is None else [value + 1, value * 2 or 1, value + 2])
    elif annotation is float:
        value = value or 0.0
        yield from (value * 1.5 + 0.125, value / 2 + 0.0625)  # the second stays below 1
    elif annotation is str:
        # (name-shaped values for the fields that read "TABLE:row=N" and "TASK:N")
        yield from ([c for c in choices if c != value] if choices
                    else [(value or "") + "-changed", "I:*=2", f"{TASKS[0]}:7"])
    elif origin is tuple and len(args) == 2 and args[1] is Ellipsis:
        value = tuple(value or ())
        for extra in _other_values(args[0], None, choices):
            yield value + (extra,)
        if len(value) > 1:
            yield value[:-1]
            yield value[::-1]  # shares that must sum to 1 (tables.family_weights)
    elif origin is tuple:
        for i, (a, v) in enumerate(zip(args, value, strict=True)):
            for other in _other_values(a, v):
                yield (*value[:i], other, *value[i + 1:])
    else:
        raise AssertionError(f"no perturbation for {annotation}")


def perturbed(obj, path):
    """`obj` with the field at `path` changed to a value its config accepts (each config
    checks its own values when it is built, `config_data.check_fields`)."""
    from icil_paper.config_data import field_choices

    parent = get_path(obj, path.rsplit(".", 1)[0]) if "." in path else obj
    name = path.rsplit(".", 1)[-1]
    annotation = typing.get_type_hints(type(parent))[name]
    choices = field_choices(type(parent)).get(name)
    refused = []
    for value in _other_values(annotation, get_path(obj, path), choices):
        try:
            return replace_path(obj, path, value)
        except ValueError as exc:
            refused.append(f"{value!r}: {exc}")
    raise AssertionError(f"no other value of {path} is accepted: {refused}")


def leaf_paths(obj, prefix=""):
    """Every leaf field path of a config, keyed or not."""
    out = []
    items = obj.items() if isinstance(obj, Mapping) else (
        (f.name, getattr(obj, f.name)) for f in dataclasses.fields(obj))
    for name, value in items:
        if dataclasses.is_dataclass(value) or isinstance(value, Mapping):
            out += leaf_paths(value, f"{prefix}{name}.")
        else:
            out.append(f"{prefix}{name}")
    return out


def units_key(units, features=True):
    """One key over a table's units: the sorted (run key, eval key[, features key]) of each. A
    table shares one run object among the units of a cell (9 runs for Table I's 237 units), so
    each object's key is computed once; equal to keying every unit."""
    units = list(units)  # alive through the call, so that no id is reused
    known = {}

    def key(obj, of):
        if id(obj) not in known:
            known[id(obj)] = of(obj)
        return known[id(obj)]

    return spec_key(sorted(
        (key(u.run, lambda r: r.key()), spec_key(u.eval),
         *((key(u.features, spec_key),) if features else ()))
        for u in units))


STAGES = {
    # stage: (key of the stage under a preset, the preset fields it reads)
    "train icrt+lipvq": (lambda p: run_spec(p, "icrt", "lipvq", tasks=TASKS).key(),
                         ("policies.icrt.", "tokenizers.lipvq.", "train.", "data.demos_per_task", "data.task_demos",
                          "data.obs", "seed")),
    "train icrt (default mlp)": (lambda p: run_spec(p, "icrt", tasks=TASKS).key(),
                                 ("policies.icrt.", "tokenizers.mlp.", "train.",
                                  "data.demos_per_task", "data.task_demos", "data.obs", "seed")),
    "train act+fast": (lambda p: run_spec(p, "act", "fast", tasks=TASKS).key(),
                       ("policies.act.", "tokenizers.fast.", "train.", "data.demos_per_task", "data.task_demos",
                        "data.obs", "seed")),
    "train bc_transformer on the preset's RoboCasa-table tasks": (
        lambda p: run_spec(p, "bc_transformer").key(),
        ("policies.bc_transformer.", "train.", "data.demos_per_task", "data.task_demos", "data.obs",
         "data.robocasa_tasks", "seed")),
    "eval icrt+lipvq": (lambda p: eval_key(run_spec(p, "icrt", "lipvq", tasks=TASKS),
                                           eval_spec(p, TASKS[0])),
                        ("policies.icrt.", "tokenizers.lipvq.", "train.", "data.demos_per_task", "data.task_demos",
                         "data.obs", "seed", "eval.")),
    "table I (every unit)": (
        lambda p: units_key(table_spec(p, "I").units()),
        ("policies.mcr.", "policies.act.", "policies.bc_transformer.", "policies.icrt.",
         *(f"tokenizers.{t}." for t in ("mlp", "bin", "fast", "vq", "lfq", "lipvq")),
         "train.", "data.demos_per_task", "data.task_demos", "data.obs", "data.robocasa_tasks", "seed",
         "eval.episodes_per_task", "eval.max_steps", "tables.icrt_seeds",
         "tables.baseline_seeds", "tables.row_seeds", "tables.image_demos_per_task",
         "tables.image_episodes_per_task", "tables.image_max_steps",
         "tables.feature_demos_per_task", "tables.feature_steps")),  # its codebook rows
    "table II (every unit)": (
        lambda p: units_key(table_spec(p, "II").units(), features=False),
        ("policies.mcr.", "policies.act.", "policies.bc_transformer.",
         *(f"tokenizers.{t}." for t in ("bin", "fast", "vq", "lfq", "lipvq")),
         # its columns are the paper's three tasks: an added ManiSkill task is not read
         "train.", "data.demos_per_task", "data.obs", "seed",
         "eval.episodes_per_task", "eval.max_steps", "tables.image_demos_per_task",
         "tables.image_episodes_per_task", "tables.image_max_steps",
         "tables.maniskill_demos_per_task", "tables.maniskill_steps",
         "tables.maniskill_episodes_per_task")),
    "table beyond (every unit)": (
        lambda p: units_key(table_spec(p, "beyond").units()),
        ("policies.icrt.",
         *(f"tokenizers.{t}." for t in ("vq", "lipvq", "fsq", "lipfsq", "rvq", "liprvq",
                                        "bspline")),
         "train.", "data.demos_per_task", "data.task_demos", "data.obs", "data.robocasa_tasks", "seed",
         "eval.episodes_per_task", "eval.max_steps", "tables.icrt_seeds",
         "tables.since_paper_seeds", "tables.row_seeds",  # Table I's seeds: "I:*=2"
         "tables.feature_demos_per_task", "tables.feature_steps")),
    "tokenizer study liprvq": (lambda p: spec_key(study_spec(p, p.tokenizers.liprvq)),
                               ("tokenizers.liprvq.", "tokenizer_study.", "data.demos_per_task",
                                "data.robocasa_tasks", "data.maniskill_tasks", "seed")),
    "tokenizer study vq": (lambda p: spec_key(study_spec(p, p.tokenizers.vq)),
                           ("tokenizers.vq.", "tokenizer_study.", "data.demos_per_task",
                            "data.robocasa_tasks", "data.maniskill_tasks", "seed")),
}


@pytest.mark.parametrize("stage", STAGES)
def test_every_field_reaches_the_key_of_every_stage_that_reads_it(stage):
    key_of, reads = STAGES[stage]
    preset = get_preset("small")
    base = key_of(preset)
    keyed = set(keyed_paths(preset))
    missing, spurious = [], []
    for path in leaf_paths(preset):
        if path == "name":
            continue  # where results are stored, not what they are
        changed = key_of(perturbed(preset, path)) != base
        should = path in keyed and path.startswith(reads)
        if should and not changed:
            missing.append(path)
        if changed and not should:
            spurious.append(path)
    assert not missing, f"{stage}: fields read but not in the key: {missing}"
    assert not spurious, f"{stage}: fields that change the key but are not read: {spurious}"


def test_only_execution_knobs_stay_out_of_keys():
    preset = get_preset("small")
    unkeyed = sorted(set(leaf_paths(preset)) - set(keyed_paths(preset)))
    assert unkeyed == ["data.root", "data.workers", "eval.record", "eval.workers", "train.ckpt_every",
                       "train.cpu_threads", "train.log_every"]
    for path in unkeyed:  # each says why in its docstring, through the metadata
        parent = get_path(preset, path.rsplit(".", 1)[0])
        f = next(f for f in dataclasses.fields(parent) if f.name == path.rsplit(".", 1)[1])
        assert f.metadata == NOT_KEYED


def test_set_overrides_are_typed_and_checked():
    preset = get_preset("smoke")
    changed = preset.with_overrides(["train.steps=3", "tokenizers.lipvq.codebook_size=16",
                                     "data.sources=human", "train.ema_decay=none",
                                     "tokenizers.lip_mlp.lipschitz.c_init=2.5",
                                     "tokenizers.vq.hidden=32,64", "train.betas=0.8,0.9"])
    assert changed.train.steps == 3 and changed.tokenizers.lipvq.codebook_size == 16
    assert changed.data.sources == ("human",) and changed.train.ema_decay is None
    assert changed.tokenizers.lip_mlp.lipschitz.c_init == 2.5
    assert changed.tokenizers.vq.hidden == (32, 64) and changed.train.betas == (0.8, 0.9)
    cases = {
        "trian.steps=3": "unknown section 'trian'. Did you mean 'train'?.*Valid section names",
        "train.stepz=3": "unknown field of train 'stepz'.*Did you mean 'steps'",
        "train.steps=abc": "train.steps: expected an integer, got 'abc'",
        "train.steps=2.5": "train.steps: expected an integer",
        "train.lr=fast": "train.lr: expected a number",
        "eval.record=maybe": "eval.record: expected true or false",
        "train=3": "train is a section",
        "train.steps": "expects SECTION.FIELD=VALUE",
        "train.betas=1": "expected 2 values",
        "train.lr=-1": "train.lr must be a finite number >= 0, got -1",
        "train.lr=0": "train.lr must be above 0",
        "train.batch_size=0": "train.batch_size counts something and must be at least 1",
        "eval.episodes_per_task=0": "must be at least 1",
        "eval.max_steps=0": "eval.max_steps counts something",
        "tokenizers.vq.hidden=32,0": "counts something",
        "policies.icrt.dropout=1": "fraction and must be below 1",
        "train.betas=0.9,1.5": "fraction and must be below 1",
        "tokenizers.vq.commitment_weight=-0.1": "finite number >= 0",
    }
    for text, message in cases.items():
        with pytest.raises(OverrideError, match=message):
            preset.with_overrides([text])


def test_every_preset_value_is_in_range():
    """The range check (`--set`) accepts every value the presets themselves use, and 0
    where it means something."""
    from icil_paper.config import PRESET_NAMES
    from icil_paper.config_data import check_range

    def walk(obj, prefix=""):
        if isinstance(obj, Mapping):  # a component section: every component's config
            for name, config in obj.items():
                yield from walk(config, f"{prefix}{name}.")
            return
        hints = typing.get_type_hints(type(obj))
        for f in dataclasses.fields(obj):
            value = getattr(obj, f.name)
            if dataclasses.is_dataclass(value) or isinstance(value, Mapping):
                yield from walk(value, f"{prefix}{f.name}.")
            else:
                yield f"{prefix}{f.name}", value, hints[f.name]

    checked = 0
    for name in PRESET_NAMES:
        for path, value, annotation in walk(get_preset(name)):
            check_range(path, value, annotation)
            checked += 1
    assert checked > 300
    preset = get_preset("smoke")
    assert preset.with_overrides(["train.warmup_steps=0", "seed=0",
                                  "tokenizers.vq.recon_weight=0"]).train.warmup_steps == 0


def test_component_configs_round_trip_by_type():
    preset = get_preset("small")
    for name in TOKENIZERS:
        cfg = preset.tokenizers.get(name)
        assert from_dict(TokenizerConfig, to_dict(cfg)) == cfg
    assert from_dict(type(preset), to_dict(preset)) == preset
    with pytest.raises(OverrideError, match="no field"):
        from_dict(TokenizerConfig, {"type": "vq", "codebook_sise": 3})
