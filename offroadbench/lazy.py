"""Lazy exports of a package: its public names imported from their submodules on first use, so that
importing the package (e.g. by a study's worker processes) does not load what those submodules need
(pandas, pyarrow, matplotlib) until a name that needs it is used."""

from __future__ import annotations

import importlib
from typing import Any, Callable, Mapping, MutableMapping

__all__ = ["lazy_exports"]


def lazy_exports(package: str, exports: Mapping[str, str],
                 namespace: MutableMapping[str, Any]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module-level ``__getattr__`` and ``__dir__`` of ``package`` (PEP 562): ``exports`` maps each
    public name to the submodule (relative to ``package``) that defines it; a name is imported on
    first use and kept in ``namespace`` (the package's ``globals()``), so later uses are plain lookups.
    An unknown name is an AttributeError as for any module."""

    def __getattr__(name: str) -> Any:
        try:
            module = exports[name]
        except KeyError:
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        value = getattr(importlib.import_module(f"{package}.{module}"), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(exports))

    return __getattr__, __dir__
