"""One registry type for everything looked up by name: terrain generators and modifiers, crater
profiles, exporters, planners, policies, executors and vehicles.

A :class:`Registry` maps names to entries. Code in this package registers entries with
:meth:`Registry.register` (or its decorator form); installed packages add entries through an
entry-point group (``[project.entry-points."offroadbench.planners"] mine = "my_pkg:MyPlanner"``),
loaded the first time the registry is read. Unknown names are :class:`~offroadbench.errors.InputError`
with the closest known names ("did you mean ...").

Example::

    PLANNERS: Registry[PlannerSpec] = Registry("planner", entry_point_group="offroadbench.planners")

    @PLANNERS.register("straight")
    def straight(...): ...

    PLANNERS.get("straigt")   # InputError: unknown planner 'straigt'; did you mean 'straight'? known: ...
"""

from __future__ import annotations

import difflib
import logging
from importlib import metadata
from typing import Callable, Generic, Iterable, Iterator, TypeVar

from offroadbench.errors import InputError

__all__ = ["Registry", "unknown_name"]

log = logging.getLogger(__name__)

T = TypeVar("T")


def unknown_name(kind: str, name: object, known: Iterable[str], *, extra: str = "") -> InputError:
    """The error for an unknown ``name`` of ``kind``: the closest known names, then all of them.

    ``extra`` is appended (e.g. "(or give a path to a .toml)").
    """
    known = sorted(known)
    close = difflib.get_close_matches(str(name), known, n=3, cutoff=0.6)
    hint = f"did you mean {' or '.join(repr(c) for c in close)}? " if close else ""
    tail = f" {extra}" if extra else ""
    return InputError(f"unknown {kind} {name!r}; {hint}known: {', '.join(known) or '(none)'}{tail}")


class Registry(Generic[T]):
    """Named entries of one kind.

    Args:
        kind: what an entry is, for messages ("planner", "terrain generator", ...).
        entry_point_group: the ``importlib.metadata`` entry-point group (or tuple of groups) whose
            entries are added on first read (None: no plug-ins).
        loader: called once before the first read, to import the modules that register the
            built-in entries (e.g. ``lambda: importlib.import_module("offroadbench.terrain")``).
        adapt: turns an entry-point's loaded object into an entry (default: the object itself); a
            TypeError or ValueError from it skips that plug-in with a warning.
    """

    def __init__(
        self,
        kind: str,
        *,
        entry_point_group: str | tuple[str, ...] | None = None,
        loader: Callable[[], object] | None = None,
        adapt: Callable[[str, object], T] | None = None,
    ) -> None:
        self.kind = kind
        self.entry_point_group = entry_point_group
        self._loader = loader
        self._adapt = adapt
        self._entries: dict[str, T] = {}
        self._loaded = False

    # ------------------------------------------------------------------ writing
    def add(self, name: str, entry: T) -> T:
        """Add ``entry`` under ``name``; a name registered twice is a programming error."""
        if not isinstance(name, str) or not name:
            raise ValueError(f"{self.kind} names are non-empty strings, got {name!r}")
        if name in self._entries:
            raise ValueError(f"{self.kind} {name!r} is registered twice")
        self._entries[name] = entry
        return entry

    def register(self, name: str, entry: T | None = None):
        """``register(name, entry)`` adds an entry; ``@register(name)`` adds the decorated object."""
        if entry is not None:
            return self.add(name, entry)

        def deco(obj):
            self.add(name, obj)
            return obj

        return deco

    # ------------------------------------------------------------------ reading
    def _ensure_loaded(self) -> None:
        if self._loaded:
            return
        self._loaded = True
        if self._loader is not None:
            self._loader()
        if self.entry_point_group:
            self._load_entry_points()

    def _load_entry_points(self) -> None:
        groups = (self.entry_point_group,) if isinstance(self.entry_point_group, str) else self.entry_point_group
        for ep in (ep for group in groups for ep in metadata.entry_points(group=group)):
            if ep.name in self._entries:
                log.warning("%s %r from package entry point %s is ignored: the name is taken", self.kind, ep.name, ep.value)
                continue
            try:
                obj = ep.load()
            except Exception as exc:  # a broken plug-in must not break the tool
                log.warning("%s plug-in %r (%s) failed to load: %s", self.kind, ep.name, ep.value, exc)
                continue
            try:
                entry = self._adapt(ep.name, obj) if self._adapt else obj
            except (TypeError, ValueError) as exc:
                log.warning("%s plug-in %r (%s) is not usable: %s", self.kind, ep.name, ep.value, exc)
                continue
            self._entries[ep.name] = entry

    def get(self, name: str) -> T:
        """The entry called ``name``; an unknown name is an InputError with close matches."""
        self._ensure_loaded()
        try:
            return self._entries[name]
        except (KeyError, TypeError):
            pass
        raise unknown_name(self.kind, name, self._entries) from None

    def names(self) -> list[str]:
        """Every registered name, sorted."""
        self._ensure_loaded()
        return sorted(self._entries)

    def items(self) -> list[tuple[str, T]]:
        """(name, entry) pairs, sorted by name."""
        self._ensure_loaded()
        return sorted(self._entries.items())

    def __contains__(self, name: object) -> bool:
        self._ensure_loaded()
        return name in self._entries

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def __len__(self) -> int:
        self._ensure_loaded()
        return len(self._entries)

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}, {len(self._entries)} entries)"
