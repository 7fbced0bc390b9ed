"""A trained action tokenizer as a portable folder: JSON config, safetensors weights, no pickle.

    icil-paper export-tokenizer runs/small/icrt+lipvq__... exported/lipvq   # icil_paper.interop

    from icil_paper.tokenizers import load_tokenizer
    tokenizer = load_tokenizer("exported/lipvq")    # eval mode; actions (B, T, A) -> codes

The folder (`save_tokenizer` writes it):

    config.json           {"format": "icil_paper.tokenizer/1",
                           "tokenizer": {"type": "lipvq", "latent_dim": 64, ...},  # its config
                           "action_dim": 7, "extra_state": {...},   # fitted non-tensor state
                           "files": {"weights.safetensors": "<sha256>", ...},
                           "facts": {...}, "source": {...}, "provenance": {...},
                           "checksum": "<sha256 of everything above>"}
    weights.safetensors   the tokenizer's state_dict (parameters and fitted buffers)
    bpe.json              FAST only: its byte-pair encoding (`tokenizers.Tokenizer.from_file`)

Loading builds the tokenizer from its config alone and loads the weights with `strict=True`;
a folder it cannot trust raises `TokenizerFolderError` (a ValueError) naming the file and the fix.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import torch

from icil_paper import plugins
from icil_paper.config_data import from_dict, to_dict
from icil_paper.fileio import atomic_write_bytes, atomic_write_json
from icil_paper.setup.provenance import git_state, package_versions
from icil_paper.tokenizers.base import ActionTokenizer
from icil_paper.tokenizers.configs import TOKENIZER_REGISTRY, TokenizerConfig
from icil_paper.tokenizers.factory import make_tokenizer

FORMAT = "icil_paper.tokenizer/1"
CONFIG_FILE = "config.json"
WEIGHTS_FILE = "weights.safetensors"
EXTRA_STATE_SUFFIX = "_extra_state"
EXTERNAL_STATE = {"bpe": "bpe.json"}
"""Extra-state entries written as files of their own (FAST's BPE JSON)."""


class TokenizerFolderError(ValueError):
    """A folder that is not an exported tokenizer this version loads; names the fix."""


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _checksum(config: Mapping[str, Any]) -> str:
    """sha256 of a config's canonical JSON, its own `checksum` left out."""
    body = {k: v for k, v in config.items() if k != "checksum"}
    return _sha256(json.dumps(body, sort_keys=True, separators=(",", ":")).encode())


def _split_state(tokenizer: ActionTokenizer) -> tuple[dict[str, torch.Tensor], dict[str, Any]]:
    """(tensors, extra states) of a tokenizer's state_dict, tensors as contiguous CPU copies."""
    tensors, extra = {}, {}
    for key, value in tokenizer.state_dict().items():
        if isinstance(value, torch.Tensor):
            tensors[key] = value.detach().cpu().contiguous().clone()
        elif key.endswith(EXTRA_STATE_SUFFIX):
            extra[key] = value
        else:  # pragma: no cover - a tokenizer that stores something torch does not
            raise TypeError(f"state_dict entry {key!r} is a {type(value).__name__}, not a tensor")
    return tensors, extra


# --------------------------------------------------------------------------- writing
def save_tokenizer(tokenizer: ActionTokenizer, folder: str | Path,
                   source: Mapping[str, Any] | None = None) -> Path:
    """Write `tokenizer` (fitted) as a portable folder; returns the folder. `source`
    (JSON-ready) says where it came from. `config.json`, which names the other files' hashes,
    is written last, so an interrupted export leaves a folder that `load_tokenizer` refuses.
    """
    from safetensors.torch import save as safetensors_bytes

    if not tokenizer.fitted:
        raise ValueError(f"the {tokenizer.name} tokenizer is not fitted: call "
                         "tokenizer.fit(trajectories) before saving it")
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise NotADirectoryError(f"{folder} is a file; pass a folder to export the tokenizer to")
    if folder.is_dir() and any(folder.iterdir()) and not (folder / CONFIG_FILE).is_file():
        raise TokenizerFolderError(f"{folder} is not empty and holds no exported tokenizer; "
                                   "pass a new folder (an earlier export there is replaced)")
    tensors, extra = _split_state(tokenizer)
    files: dict[str, bytes] = {WEIGHTS_FILE: safetensors_bytes(
        tensors, metadata={"format": FORMAT, "tokenizer": tokenizer.config.type})}
    extra_json: dict[str, Any] = {}
    for key, state in extra.items():
        state = dict(state) if isinstance(state, Mapping) else state
        if isinstance(state, dict):
            for entry in EXTERNAL_STATE:
                if isinstance(state.get(entry), str):
                    name = key[:-len(EXTRA_STATE_SUFFIX)].replace(".", "_") + EXTERNAL_STATE[entry]
                    files[name] = state[entry].encode()
                    state[entry] = {"file": name}
        extra_json[key] = state
    config: dict[str, Any] = {
        "format": FORMAT,
        "tokenizer": to_dict(tokenizer.config),
        "action_dim": tokenizer.action_dim,
        "extra_state": extra_json,
        "files": {name: _sha256(data) for name, data in files.items()},
        "facts": {"name": tokenizer.name, "discrete": tokenizer.discrete,
                  "latent_dim": tokenizer.latent_dim, "codebook_size": tokenizer.codebook_size,
                  "context_steps": tokenizer.context_steps,
                  "n_tensors": len(tensors), "n_values": sum(t.numel() for t in tensors.values())},
        "source": dict(source or {}),
        **({"plugins": used} if (used := plugins.record_of(to_dict(tokenizer.config)))
           else {}),
        "provenance": {"git": git_state(),
                       "packages": package_versions(("torch", "safetensors", "tokenizers",
                                                     "vector-quantize-pytorch"))},
    }
    config["checksum"] = _checksum(json.loads(json.dumps(config)))
    folder.mkdir(parents=True, exist_ok=True)
    for name, data in files.items():
        atomic_write_bytes(folder / name, data)
    atomic_write_json(folder / CONFIG_FILE, config)
    return folder


# --------------------------------------------------------------------------- reading
def read_config(folder: str | Path) -> dict[str, Any]:
    """An exported folder's `config.json`, checked: its format version and its checksum."""
    folder = Path(folder)
    if not folder.is_dir():
        raise FileNotFoundError(f"no exported tokenizer at {folder} (export one: icil-paper "
                                "export-tokenizer RUN_DIR OUT)")
    path = folder / CONFIG_FILE
    if not path.is_file():
        raise TokenizerFolderError(f"{folder} has no {CONFIG_FILE}: it is not an exported "
                                   "tokenizer (export one: icil-paper export-tokenizer RUN_DIR OUT)")
    try:
        config = json.loads(path.read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise TokenizerFolderError(f"{path} is damaged (not JSON: {exc}); export the "
                                   "tokenizer again") from None
    found = config.get("format") if isinstance(config, dict) else None
    if found != FORMAT:
        raise TokenizerFolderError(f"{folder} holds format {found!r}, this version reads "
                                   f"{FORMAT!r}; export the tokenizer again with this version")
    if config.get("checksum") != _checksum(config):
        raise TokenizerFolderError(f"{path} does not match its checksum (edited or damaged); "
                                   "export the tokenizer again instead of editing it")
    return config


def _read_checked(folder: Path, name: str, expected: str) -> bytes:
    path = folder / name
    if not path.is_file():
        raise TokenizerFolderError(f"{path} is missing; export the tokenizer again")
    data = path.read_bytes()
    if _sha256(data) != expected:
        raise TokenizerFolderError(f"{path} is damaged (its sha256 is not the one "
                                   f"{CONFIG_FILE} records: truncated or replaced); export "
                                   "the tokenizer again")
    return data


def _check_plugins(folder: Path, config: Mapping[str, Any], specs: Sequence[str]) -> None:
    # load `specs`; refuse a tokenizer type no loaded code registers, naming its plugin
    plugins.load_plugins(specs)
    name = (config.get("tokenizer") or {}).get("type")
    if not isinstance(name, str) or name in TOKENIZER_REGISTRY.configs:
        return
    needs = config.get("plugins") or []
    if needs:
        first = needs[0]["path"] if needs[0].get("source") == "file" else needs[0]["spec"]
        raise TokenizerFolderError(
            f"{folder} holds the tokenizer {name!r} of the plugin {plugins.needed_by(needs)}, which is "
            f"not loaded: load it first (load_tokenizer({str(folder)!r}, plugins=[{first!r}]), "
            f"or --plugin {first} on the command line)")
    raise TokenizerFolderError(f"{folder} holds the tokenizer {name!r}, which this version does "
                               "not register and no loaded plugin provides; load the plugin "
                               "that registers it (plugins=[...] or --plugin)")


def load_tokenizer(folder: str | Path, map_location: Any = "cpu",
                   plugins: Sequence[str] = ()) -> ActionTokenizer:
    """The tokenizer an exported folder holds, rebuilt from its config, in eval mode.

    `plugins`: modules or files to load first, for a tokenizer a plugin registers. Raises
    FileNotFoundError, TokenizerFolderError or PluginError.
    """
    from safetensors import SafetensorError
    from safetensors.torch import load as safetensors_load

    folder = Path(folder)
    config = read_config(folder)
    _check_plugins(folder, config, plugins)
    files = config.get("files") or {}
    if WEIGHTS_FILE not in files:
        raise TokenizerFolderError(f"{folder / CONFIG_FILE} names no {WEIGHTS_FILE}; export "
                                   "the tokenizer again")
    data = {name: _read_checked(folder, name, sha) for name, sha in files.items()}
    try:
        state: dict[str, Any] = safetensors_load(data[WEIGHTS_FILE])
    except (SafetensorError, ValueError) as exc:
        raise TokenizerFolderError(f"{folder / WEIGHTS_FILE} is not a safetensors file "
                                   f"({exc}); export the tokenizer again") from None
    for key, extra in (config.get("extra_state") or {}).items():
        if isinstance(extra, dict):
            extra = dict(extra)
            for entry, value in extra.items():
                if isinstance(value, dict) and "file" in value:
                    if value["file"] not in data:
                        raise TokenizerFolderError(f"{folder / CONFIG_FILE} names {value['file']}"
                                                   " without its sha256; export it again")
                    extra[entry] = data[value["file"]].decode()
        state[key] = extra
    try:
        tokenizer = make_tokenizer(from_dict(TokenizerConfig, config["tokenizer"]),
                                   int(config["action_dim"]))
        tokenizer.load_state_dict(state, strict=True)
    except (KeyError, TypeError, ValueError, RuntimeError) as exc:
        detail = " ".join(str(exc).split())[:200]
        raise TokenizerFolderError(f"{folder}: its weights do not fit its config ({detail}); "
                                   "export the tokenizer again with this version") from None
    return tokenizer.to(map_location).eval()
