"""Chapter 01's view of the preset: every field of the active preset with its docstring.

    preset_fields(preset)                     # frame: field -> value, meaning
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Sequence
from typing import Any

import pandas as pd

from icil_paper.config import Preset, field_docs
from icil_paper.config_data import get_path

PRESET_SECTIONS = ("data", "train", "eval", "tables", "tokenizer_study", "policies.icrt",
                   "tokenizers.lipvq")
"""The parts of a preset chapter 01 lists."""


def config_fields(config: Any, path: str) -> Iterator[tuple[str, Any, str]]:
    """(dotted path, value, docstring) of every leaf field of a config dataclass."""
    docs = field_docs(type(config))
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if dataclasses.is_dataclass(value):
            yield from config_fields(value, f"{path}.{f.name}")
        else:
            yield f"{path}.{f.name}", value, docs.get(f.name, "")


def preset_fields(preset: Preset, sections: Sequence[str] = PRESET_SECTIONS) -> pd.DataFrame:
    """One row per leaf field of `sections`: value and docstring, indexed by its `--set` path."""
    rows = []
    for section in sections:
        rows += [{"field": name, "value": str(value), "meaning": doc}
                 for name, value, doc in config_fields(get_path(preset, section), section)]
    return pd.DataFrame(rows).set_index("field")
