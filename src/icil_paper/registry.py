"""Registries by name, with lazy imports and errors that list the valid names.

Experiments are data (`{"policy": "icrt", "tokenizer": "lipvq"}`), so every name that a
user can type goes through `check_name`, and a typo fails with the list of valid names.
"""

from __future__ import annotations

import difflib
import importlib
from collections.abc import Iterable, Iterator, Mapping
from typing import Any

ENTRY_POINT_LOADER = "icil_paper.plugins:load_entry_points"
"""What loads and checks a registry's entry points, imported on first use (it imports this
module)."""


class UnknownNameError(ValueError):
    """A preset, task, policy or tokenizer name that does not exist."""


class NameClashError(ValueError):
    """A component registered under a name another class already holds."""

    def __init__(self, kind: str, name: str, message: str):
        super().__init__(message)
        self.kind = kind
        self.name = name


def check_name(kind: str, name: str, valid: Iterable[str]) -> str:
    """Return `name` if it is in `valid`, else raise UnknownNameError listing the valid names."""
    valid = list(valid)
    if name in valid:
        return name
    hint = difflib.get_close_matches(str(name), valid, n=1)
    did_you_mean = f" Did you mean {hint[0]!r}?" if hint else ""
    raise UnknownNameError(
        f"unknown {kind} {name!r}.{did_you_mean} Valid {kind} names: {', '.join(valid)}"
    )


class Registry(Mapping[str, Any]):
    """A name -> object mapping whose entries are "module:attribute" strings imported on use.

    Lazy imports keep `icil-paper --help` fast and let a part of the library (say the
    ManiSkill suite) fail to import without breaking the rest.
    """

    def __init__(self, kind: str, entries: Mapping[str, str]):
        self.kind = kind
        self._entries = dict(entries)
        self._loaded: dict[str, Any] = {}

    def __getitem__(self, name: str) -> Any:
        self.discover()
        check_name(self.kind, name, self._entries)
        if name not in self._loaded:
            module, _, attribute = self._entries[name].partition(":")
            self._loaded[name] = getattr(importlib.import_module(module), attribute)
        return self._loaded[name]

    def __iter__(self) -> Iterator[str]:
        self.discover()
        return iter(self._entries)

    def __len__(self) -> int:
        self.discover()
        return len(self._entries)

    def discover(self) -> None:
        """Load what else adds entries (plugins: `ComponentRegistry`); nothing here."""

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}, {list(self._entries)})"


class ComponentRegistry(Registry):
    """A registry whose entries are added by a decorator on each component's config class
    (LeRobot's `register_subclass`): the one place a tokenizer or a policy is named.

        TOKENIZERS = ComponentRegistry("tokenizer", TokenizerConfig)

        @TOKENIZERS.register("vq", "icil_paper.tokenizers.vq:VQTokenizer")
        @dataclass(frozen=True)
        class VQConfig(TokenizerConfig): ...

    `register(name, model)` sets the config class's `type` to `name` and records it
    (`configs`, in registration order) with its model, a "module:attribute" string imported
    on first use, or a bare attribute name of the config's own module (a component written
    as one file). The registry's names, the presets' sections (`icil_paper.config`) and the
    command line's choices are read from it.

    Plugins: on first use (`configs`, a name looked up, the names listed) the registry loads
    the entry points of its `group` (`icil_paper.tokenizers`, `icil_paper.policies`) that
    installed packages declare, through `icil_paper.plugins`, which checks each of them.
    `probe`, a "module:function" imported on use, is the kind's own check of a component a
    plugin registers: `function(config) -> str | None` builds the component from its
    default config and says in words what is wrong with it (None: nothing).
    """

    def __init__(self, kind: str, base: type, group: str | None = None,
                 probe: str | None = None):
        super().__init__(kind, {})
        self.base = base
        self.group = group
        self.probe = probe
        self._configs: dict[str, type] = {}
        self._discovered = group is None

    @property
    def configs(self) -> dict[str, type]:
        """name -> config class, in registration order (built-ins, then plugins)."""
        self.discover()
        return self._configs

    def discover(self) -> None:
        """Load this registry's entry-point plugins, once (`icil_paper.plugins`)."""
        if self._discovered:
            return
        self._discovered = True  # set first: a plugin's own registrations come back here
        module, _, function = ENTRY_POINT_LOADER.partition(":")
        getattr(importlib.import_module(module), function)(self)

    def register(self, name: str, model: str):
        """A class decorator registering a config class of `self.base` under `name`."""

        def decorate(cls: type) -> type:
            if not (isinstance(cls, type) and issubclass(cls, self.base)):
                raise TypeError(f"register({name!r}) decorates a subclass of "
                                f"{self.base.__name__}, got {cls!r}")
            old = self._configs.get(name)
            if old is not None and (old.__module__, old.__qualname__) != (cls.__module__,
                                                                          cls.__qualname__):
                raise NameClashError(self.kind, name,
                                     f"{self.kind} {name!r} is registered twice: by "
                                     f"{old.__module__}.{old.__qualname__} and "
                                     f"{cls.__module__}.{cls.__qualname__}; rename one")
            cls.type = name
            self._configs[name] = cls
            self._entries[name] = model if ":" in model else f"{cls.__module__}:{model}"
            self._loaded.pop(name, None)
            return cls

        return decorate
