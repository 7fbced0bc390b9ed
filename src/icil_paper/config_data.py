"""Typed configs as data: serialisation, content keys and `--set` overrides.

Every knob of the library is a field of a frozen dataclass with a docstring under it
(`field_docs` reads them). Component configs (one per tokenizer, one per policy) carry a
class-level `type` naming the registered component, so a config written as JSON can be
read back into the right class:

    cfg = ICRTConfig(d_model=64)
    d = to_dict(cfg)                     # {"type": "icrt", "d_model": 64, ...}
    from_dict(PolicyConfig, d) == cfg    # the "type" key picks ICRTConfig
    spec_key(run_spec)                   # 16 hex digits over every field that shapes a result
    with_overrides(preset, ["train.steps=3", "tokenizers.lipvq.codebook_size=512"])

A field that cannot change a result (workers, logging) is declared with
`metadata=NOT_KEYED` and left out of `spec_key`; one added after records were made, with
`metadata=KEYED_WHEN_SET`, enters the key only where it differs from its default. Every
config checks its own values when built (`check_fields`): ranges, no empty values, `CHOICES`.
"""

from __future__ import annotations

import ast
import dataclasses
import functools
import hashlib
import inspect
import json
import math
import textwrap
import types
import typing
from collections.abc import Mapping, Sequence
from typing import Any

from icil_paper.registry import REGISTRIES, check_name

NOT_KEYED = {"key": False}
"""Field metadata of a knob that cannot change a result (workers, logging, threads)."""
KEYED_WHEN_SET = {"key": "when_set"}
"""Field metadata of a knob in the key only where it is not at its default."""


class OverrideError(ValueError):
    """A `--set PATH=VALUE` that names no field or gives a value of the wrong type."""


class ConfigError(ValueError):
    """A config value that no component can use, refused when the config is built."""


# --------------------------------------------------------------------------- docs
def field_docs(cls: type) -> dict[str, str]:
    """{field: the docstring under it} of a config dataclass and its bases (of a component
    section: {component: its config's docstring})."""
    if _is_section(cls):
        return cls.field_docs()
    return _source_docs(cls)


@functools.cache
def _source_docs(cls: type) -> dict[str, str]:
    docs: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        if not dataclasses.is_dataclass(klass) or klass is object:
            continue
        try:
            source = textwrap.dedent(inspect.getsource(klass))
        except (OSError, TypeError):
            continue
        body = ast.parse(source).body[0].body
        for node, following in zip(body, body[1:], strict=False):
            if (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)
                    and isinstance(following, ast.Expr)
                    and isinstance(following.value, ast.Constant)):
                docs[node.target.id] = str(following.value.value).strip()
    return docs


# --------------------------------------------------------------------------- types
def _is_section(obj: Any) -> bool:
    """A preset's component section (`config.ComponentConfigs`)."""
    cls = obj if isinstance(obj, type) else type(obj)
    return issubclass(cls, Mapping) and hasattr(cls, "registered")


def _names(obj: Any) -> list[str]:
    """The field names of a config dataclass, or the component names of a section."""
    return list(obj) if _is_section(obj) else [f.name for f in dataclasses.fields(obj)]


def _replace(obj: Any, **changes: Any) -> Any:
    return obj.replace(**changes) if _is_section(obj) else dataclasses.replace(obj, **changes)


_hints = functools.cache(typing.get_type_hints)


def config_class(base: type, type_name: str) -> type:
    """The registered config class of `base`'s kind (a subclass of `base`) named `type_name`."""
    candidates = {name: c for r in REGISTRIES.values() for name, c in r.configs.items()
                  if issubclass(c, base)}
    return candidates[check_name(f"{base.__name__} type", type_name, candidates)]


# --------------------------------------------------------------------------- to / from dict
def to_dict(obj: Any, keyed_only: bool = False) -> Any:
    """A JSON-ready copy of a config: dataclasses become dicts (with their `type` where
    they have one), tuples become lists. `keyed_only` drops NOT_KEYED fields."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        out: dict[str, Any] = {}
        if getattr(obj, "type", None):
            out["type"] = obj.type
        for f in dataclasses.fields(obj):
            value, key = getattr(obj, f.name), f.metadata.get("key", True)
            if keyed_only and (key is False or key == "when_set" and value == f.default):
                continue
            out[f.name] = to_dict(value, keyed_only)
        return out
    if isinstance(obj, Mapping):
        return {str(k): to_dict(v, keyed_only) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_dict(v, keyed_only) for v in obj]
    return obj


def from_dict(cls: type, data: Mapping[str, Any]) -> Any:
    """Rebuild a config of class `cls` (or of the subclass its "type" names) from `to_dict`;
    unknown keys raise OverrideError, missing keys take the defaults."""
    if not isinstance(data, Mapping):
        raise OverrideError(f"{cls.__name__} must be read from a mapping, got {type(data).__name__}")
    if _is_section(cls):
        return cls.from_dict(data)
    if "type" in data:
        cls = config_class(cls, str(data["type"]))
    hints = _hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - set(fields) - {"type"})
    if unknown:
        raise OverrideError(f"{cls.__name__} has no field(s) {unknown}; valid: {sorted(fields)}")
    values = {name: _coerce(hints[name], value, f"{cls.__name__}.{name}")
              for name, value in data.items() if name != "type"}
    return cls(**values)


def _coerce(annotation: Any, value: Any, where: str) -> Any:
    """`value` (from JSON or a parsed string) as an instance of `annotation`, or OverrideError."""
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if annotation is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _coerce(arg, value, where)
            except OverrideError:
                pass
        raise OverrideError(f"{where}: expected {_type_name(annotation)}, got {value!r}")
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise OverrideError(f"{where}: expected {_type_name(annotation)}, got {value!r}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_coerce(args[0], v, where) for v in value)
        if len(args) != len(value):
            raise OverrideError(f"{where}: expected {len(args)} values, got {len(value)}")
        return tuple(_coerce(a, v, where) for a, v in zip(args, value, strict=True))
    if origin is typing.Literal:
        if value not in args:
            raise OverrideError(f"{where}: expected one of {list(args)}, got {value!r}")
        return value
    if dataclasses.is_dataclass(annotation) or _is_section(annotation):
        if isinstance(value, Mapping) and not _is_section(value):
            return from_dict(annotation, value)
        return value
    if annotation in (bool, int, float, str):  # JSON's scalars; a bool is no number
        if annotation is int and isinstance(value, float) and value.is_integer():
            return int(value)
        kinds = (int, float) if annotation is float else annotation
        if isinstance(value, kinds) and isinstance(value, bool) == (annotation is bool):
            return float(value) if annotation is float else value
    elif isinstance(annotation, type) and isinstance(value, annotation):
        return value
    raise OverrideError(f"{where}: expected {_type_name(annotation)}, got {value!r}")


def _type_name(annotation: Any) -> str:
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_type_name(a) for a in args)
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return f"a comma-separated list of {_type_name(args[0])}"
        return f"{len(args)} comma-separated values"
    if annotation is type(None):
        return "none"
    return {int: "an integer", float: "a number", bool: "true or false",
            str: "a string"}.get(annotation, getattr(annotation, "__name__", str(annotation)))


# --------------------------------------------------------------------------- keys
def canonical_json(obj: Any) -> str:
    """JSON with sorted keys and no whitespace: the text a key is taken over."""
    return json.dumps(to_dict(obj), sort_keys=True, separators=(",", ":"), default=json_default)


def json_default(obj: Any) -> Any:
    """JSON for what `json.dumps` does not know: arrays and tensors, sets, paths."""
    if hasattr(obj, "tolist"):  # numpy arrays and scalars, torch tensors
        return obj.tolist()
    if isinstance(obj, (set, frozenset)):
        return sorted(obj)
    if hasattr(obj, "__fspath__"):
        return str(obj)
    raise TypeError(f"{type(obj).__name__} is not JSON serializable")


def content_hash(obj: Any) -> str:
    """16 hex digits of SHA-256 over the canonical JSON of `obj`."""
    return hashlib.sha256(canonical_json(obj).encode()).hexdigest()[:16]


def spec_key(spec: Any) -> str:
    """The content key of a spec: a hash of every field that can change its result."""
    return content_hash(to_dict(spec, keyed_only=True))


def keyed_paths(obj: Any, prefix: str = "") -> list[str]:
    """Dotted paths of every keyed leaf field of a config (nested configs expanded)."""
    items = obj.items() if _is_section(obj) else (
        (f.name, getattr(obj, f.name)) for f in dataclasses.fields(obj)
        if f.metadata.get("key", True) is not False)  # NOT_KEYED
    paths = []
    for name, value in items:
        if dataclasses.is_dataclass(value) or _is_section(value):
            paths += keyed_paths(value, f"{prefix}{name}.")
        else:
            paths.append(f"{prefix}{name}")
    return paths


# --------------------------------------------------------------------------- overrides
def get_path(obj: Any, path: str) -> Any:
    """The value at a dotted path (`train.steps`)."""
    for part in path.split("."):
        obj = getattr(obj, part)
    return obj


def replace_path(obj: Any, path: str, value: Any, _done: str = "") -> Any:
    """A copy of `obj` with the field at dotted `path` set to `value` (typed as declared)."""
    head, _, rest = path.partition(".")
    fields = _names(obj)
    if head not in fields:
        kind = f"field of {_done.rstrip('.')}" if _done else "section"
        try:
            check_name(kind, head, fields)
        except ValueError as exc:
            raise OverrideError(str(exc)) from None
    current = getattr(obj, head)
    if rest:
        if not (dataclasses.is_dataclass(current) or _is_section(current)):
            raise OverrideError(f"{type(obj).__name__}.{head} is a value, not a section; "
                                f"set it as `{head}=...`")
        return _replace(obj, **{head: replace_path(current, rest, value, f"{_done}{head}.")})
    if dataclasses.is_dataclass(current) or _is_section(current):
        valid = ", ".join(_names(current))
        raise OverrideError(f"{head} is a section; set one of its fields: {head}.<field> with "
                            f"<field> one of {valid}")
    annotation, where = _hints(type(obj))[head], f"{_done}{head}"
    if value is not None and not isinstance(value, (list, tuple)) and _accepts_sequence(annotation):
        value = [value]  # `--set data.sources=human` on a tuple field
    try:
        changed = dataclasses.replace(obj, **{head: _coerce(annotation, value, where)})
    except OverrideError:
        raise
    except ValueError:  # refused by the config's own check: name the range by the path
        check_range(where, value, annotation)
        raise
    check_range(where, value, annotation)
    return changed


def parse_override(text: str) -> tuple[str, Any]:
    """`"train.steps=3"` -> ("train.steps", 3): JSON where it parses, else a string; a
    comma-separated value becomes a list."""
    path, sep, raw = text.partition("=")
    path = path.strip()
    if not sep or not path:
        raise OverrideError(f"--set expects SECTION.FIELD=VALUE, got {text!r}")
    raw = raw.strip()
    if raw.lower() in ("none", "null"):
        return path, None
    if raw.lower() in ("true", "false"):
        return path, raw.lower() == "true"
    try:
        return path, json.loads(raw)
    except json.JSONDecodeError:
        pass
    if "," in raw:
        return path, [parse_override(f"x={part}")[1] for part in raw.split(",") if part.strip()]
    return path, raw


def with_overrides(obj: Any, overrides: Sequence[str]) -> Any:
    """`obj` with every `PATH=VALUE` of `overrides` applied in order (OverrideError on a bad one)."""
    for text in overrides or ():
        path, value = parse_override(text)
        try:
            obj = replace_path(obj, path, value)
        except ValueError as exc:  # OverrideError, ConfigError, UnknownNameError
            raise OverrideError(f"--set {text}: {exc}") from None
    return obj


ZERO_ALLOWED = frozenset({"seed", "expert_seeds", "dead_code_restart", "warmup_steps",
                          "cpu_threads", "pretrain_steps", "query_len"})
"""Integer fields for which 0 means something; every other integer field is at least 1."""
MORE_THAN_ZERO = frozenset({"lr", "pretrain_lr", "scale", "c_init", "grad_clip",
                            "stage_budget_hours"})
"""Float fields that must be above 0 (other floats, weights and rates, may be 0)."""
BELOW_ONE = frozenset({"dropout", "eval_fraction", "ema_decay", "betas"})
"""Fractions: below 1 (and at least 0)."""


def check_range(path: str, value: Any, annotation: Any = None,
                error: type[ValueError] = OverrideError) -> None:
    """Refuse (`error`) a number no config field can take: negative or not finite, an integer
    field below 1 (but `ZERO_ALLOWED`), `MORE_THAN_ZERO` at 0, `BELOW_ONE` at 1."""
    name = path.rsplit(".", 1)[-1]
    counts = _integer_field(annotation) and name not in ZERO_ALLOWED
    for v in value if isinstance(value, (list, tuple)) else [value]:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            continue
        if not math.isfinite(v) or v < 0:
            raise error(f"{path} must be a finite number >= 0, got {v}")
        if counts and v < 1:
            raise error(f"{path} counts something and must be at least 1, got {v}")
        if name in MORE_THAN_ZERO and v <= 0:
            raise error(f"{path} must be above 0, got {v}")
        if name in BELOW_ONE and v >= 1:
            raise error(f"{path} is a fraction and must be below 1, got {v}")


EMPTY_ALLOWED = frozenset({"hidden", "decoder_hidden", "maniskill_tasks", "row_seeds",
                           "seed_stages", "stage_stops", "task_demos", "primary_claims",
                           "episodes_per_task_by_suite"})
"""Tuple fields that may be empty; every other tuple or string field needs a value."""


def field_choices(cls: type, attr: str = "CHOICES") -> dict[str, Any]:
    """{field name: its valid strings} from the `CHOICES` of a config class and its bases
    (`attr="AT_LEAST"`: {field name: the floor above 1 of each of its integers})."""
    out: dict[str, Any] = {}
    for klass in reversed(cls.__mro__):
        out.update(vars(klass).get(attr, {}))
    return out


class Checked:
    """Base of the configs: each checks its own fields when it is built (`check_fields`)."""

    def __post_init__(self) -> None:
        check_fields(self)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (tuples become lists, component configs carry their type)."""
        return to_dict(self)


def check_fields(obj: Any) -> None:
    """The checks every config's `__post_init__` makes of its own fields: `check_range`, no
    empty value (but `EMPTY_ALLOWED`), strings among `field_choices`, integers at least their
    `AT_LEAST` floor; None passes."""
    cls = type(obj)
    hints = _hints(cls)
    choices, floors = field_choices(cls), field_choices(cls, "AT_LEAST")
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if value is None or dataclasses.is_dataclass(value):
            continue
        where = f"{cls.__name__}.{f.name}"
        check_range(where, value, hints.get(f.name), error=ConfigError)
        many = isinstance(value, (list, tuple))
        if many and not value and f.name not in EMPTY_ALLOWED:
            raise ConfigError(f"{where} needs at least one value, got an empty list")
        valid, low = choices.get(f.name), floors.get(f.name)
        for item in value if many else [value]:
            if low is not None and item < low:
                raise ConfigError(f"{where} must be at least {low}{' each' if many else ''}, "
                                  f"got {value}")
            if not isinstance(item, str):
                continue
            if not item.strip():
                one_of = f" (one of {', '.join(valid)})" if valid else ""
                raise ConfigError(f"{where} needs a value{one_of}, got an empty string")
            if valid is not None:
                check_name(where, item, valid)


def _integer_field(annotation: Any) -> bool:
    """int, int | None or tuple[int, ...]."""
    if annotation is int:
        return True
    return any(_integer_field(a) for a in typing.get_args(annotation) if a is not type(None)
               and a is not Ellipsis)


def _accepts_sequence(annotation: Any) -> bool:
    origin = typing.get_origin(annotation)
    return origin is tuple or origin in (typing.Union, types.UnionType) and any(
        _accepts_sequence(a) for a in typing.get_args(annotation))
