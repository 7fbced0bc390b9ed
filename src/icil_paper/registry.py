"""Registries by name, filled by decorators, with errors that list the valid names.

Experiments are data (`{"policy": "icrt", "tokenizer": "lipvq"}`), so every name that a
user can type goes through `check_name`, and a typo fails with the list of valid names.
"""

from __future__ import annotations

import difflib
import sys
from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import Any


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


REGISTRIES: dict[str, ComponentRegistry] = {}
"""kind -> its registry, added as each is built."""


class ComponentRegistry(Mapping[str, type]):
    """Components of one kind by name: `configs` (name -> config class) and this mapping (name
    -> model class), each filled by a decorator.

        TOKENIZER_REGISTRY = ComponentRegistry("tokenizer", TokenizerConfig)
        register_tokenizer = TOKENIZER_REGISTRY.register
        register_tokenizer_model = TOKENIZER_REGISTRY.model

        @register_tokenizer("vq")                # configs.py (torch-free)
        @dataclass(frozen=True)
        class VQConfig(TokenizerConfig): ...

        @register_tokenizer_model("vq")          # vq.py
        class VQTokenizer(ActionTokenizer): ...

    Config modules stay torch-free. A component of one file (a plugin) may name its model in
    the config's decorator: `register("toy", ToyTokenizer)` or `register("toy", "ToyTokenizer")`.
    `group` is the plugins' entry-point group; `probe(config) -> str | None` the kind's check
    of a plugin's component.
    """

    def __init__(self, kind: str, base: type, group: str | None = None):
        self.kind = kind
        self.base = base
        self.group = group
        self.configs: dict[str, type] = {}
        """name -> config class, in registration order (built-ins, then plugins)."""
        self.models: dict[str, type | str] = {}
        """name -> model class (or its name in the config's module)."""
        self.probe: Callable[[Any], str | None] | None = None
        REGISTRIES[kind] = self

    def register(self, name: str, model: type | str | None = None):
        """A class decorator registering a config class of `self.base` under `name` (and
        its model, for a component of one file)."""

        def decorate(cls: type) -> type:
            if not (isinstance(cls, type) and issubclass(cls, self.base)):
                raise TypeError(f"register({name!r}) decorates a subclass of "
                                f"{self.base.__name__}, got {cls!r}")
            old = self.configs.get(name)
            if old is not None and (old.__module__, old.__qualname__) != (cls.__module__,
                                                                          cls.__qualname__):
                raise NameClashError(self.kind, name,
                                     f"{self.kind} {name!r} is registered twice: by "
                                     f"{old.__module__}.{old.__qualname__} and "
                                     f"{cls.__module__}.{cls.__qualname__}; rename one")
            cls.type = name
            self.configs[name] = cls
            if model is not None:
                self.models[name] = model
            return cls

        return decorate

    def model(self, name: str):
        """A class decorator registering the model class built from config `name`."""

        def decorate(cls: type) -> type:
            self.models[name] = cls
            return cls

        return decorate

    def default(self, name: str, **fields: Any) -> Any:
        """The default config of component `name`, with some fields changed."""
        return self.configs[check_name(self.kind, name, self.configs)](**fields)

    def forget(self, names: Iterable[str]) -> None:
        """Unregister components (a plugin that failed its checks)."""
        for name in names:
            self.configs.pop(name, None)
            self.models.pop(name, None)

    def __getitem__(self, name: str) -> type:
        check_name(self.kind, name, self.configs)
        model = self.models.get(name)
        if isinstance(model, str):  # a class of the config's own module, defined after it
            model = getattr(sys.modules[self.configs[name].__module__], model, None)
        if model is None:
            raise LookupError(f"{self.kind} {name!r} has a config but no model class: "
                              f"decorate it with @register_{self.kind}_model({name!r}) "
                              f"or name it in @register_{self.kind}({name!r}, ModelClass)")
        return model

    def __iter__(self) -> Iterator[str]:
        return iter(self.configs)

    def __len__(self) -> int:
        return len(self.configs)

    def __contains__(self, name: object) -> bool:
        return name in self.configs

    def __repr__(self) -> str:
        return f"ComponentRegistry({self.kind!r}, {list(self.configs)})"
