"""Helpers shared by every frozen config: validation, loading from dicts/TOML, stable ids.

Configs are ``@dataclass(frozen=True, kw_only=True)`` classes whose fields carry SI units and
a docstring-style comment. They validate in ``__post_init__`` with the helpers below, so every
error names the field, the value and what is allowed.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import tomllib
import types
import typing
from pathlib import Path
from typing import Any, TypeVar

from offroadbench.errors import InputError

T = TypeVar("T")

__all__ = [
    "check_range",
    "check_int",
    "check_choice",
    "from_dict",
    "to_dict",
    "config_id",
    "load_toml",
    "set_dotted",
    "parse_set_value",
]


# --------------------------------------------------------------------------- validation
def _label(owner: object, field: str) -> str:
    return f"{type(owner).__name__}.{field}" if owner is not None else field


def check_range(
    owner: object,
    field: str,
    value: float,
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
) -> None:
    """Raise InputError unless ``value`` is a finite number within the interval.

    ``lo_open``/``hi_open`` exclude the end points, e.g. D in (2, 3).
    """
    name = _label(owner, field)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"{name} must be a finite number, got {value!r}")
    bad_lo = lo is not None and (value <= lo if lo_open else value < lo)
    bad_hi = hi is not None and (value >= hi if hi_open else value > hi)
    if bad_lo or bad_hi:
        left = "(" if lo_open or lo is None else "["
        right = ")" if hi_open or hi is None else "]"
        lo_s = "-inf" if lo is None else f"{lo:g}"
        hi_s = "inf" if hi is None else f"{hi:g}"
        raise InputError(f"{name} = {value!r} is out of range; allowed: {left}{lo_s}, {hi_s}{right}")


def check_int(owner: object, field: str, value: int, lo: int | None = None, hi: int | None = None) -> None:
    """Raise InputError unless ``value`` is an integer within [lo, hi]."""
    name = _label(owner, field)
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(f"{name} must be an integer, got {value!r}")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise InputError(
            f"{name} = {value} is out of range; allowed: "
            f"{'-inf' if lo is None else lo} .. {'inf' if hi is None else hi}"
        )


def did_you_mean(names, known) -> str:
    """``" (did you mean 'x'?)"`` for the known names closest to any of ``names`` (difflib), or ``""``:
    the tail of an unknown-name message, after the list of known names."""
    import difflib

    known = [str(k) for k in known]
    close = [c for n in names for c in difflib.get_close_matches(str(n), known, n=2, cutoff=0.6)]
    close = list(dict.fromkeys(close))
    return f" (did you mean {' or '.join(repr(c) for c in close)}?)" if close else ""


def check_choice(owner: object, field: str, value: str, allowed) -> None:
    """Raise InputError unless ``value`` is one of ``allowed`` (naming the closest allowed values)."""
    if value not in allowed:
        raise InputError(f"{_label(owner, field)} = {value!r} is not known; allowed: {', '.join(map(str, allowed))}"
                         f"{did_you_mean([value], allowed)}")


# --------------------------------------------------------------------------- dict / TOML
def _coerce(value: Any, annotation: Any, name: str) -> Any:
    """Light coercion from TOML types to the field's annotation (ints to floats, lists to tuples)."""
    origin = typing.get_origin(annotation)
    if annotation is float and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if origin is tuple and not isinstance(value, (list, tuple)):
        raise InputError(f"{name} = {value!r:.60}: expected a list")
    if origin is tuple and isinstance(value, list):
        args = typing.get_args(annotation)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_coerce(v, args[0], name) for v in value)
        if args and len(args) == len(value):
            return tuple(_coerce(v, a, name) for a, v in zip(args, value, strict=True))
        return tuple(value)
    if origin in (types.UnionType, typing.Union):
        for arg in typing.get_args(annotation):
            if arg is float and isinstance(value, int) and not isinstance(value, bool):
                return float(value)
    return value


def dataclass_type(annotation: Any) -> type | None:
    """The config class of a field annotated ``SomeConfig`` or ``SomeConfig | None``, else None."""
    if dataclasses.is_dataclass(annotation) and isinstance(annotation, type):
        return annotation
    if typing.get_origin(annotation) in (types.UnionType, typing.Union):
        classes = [a for a in typing.get_args(annotation) if dataclasses.is_dataclass(a) and isinstance(a, type)]
        if len(classes) == 1:
            return classes[0]
    return None


def _field_default(f: dataclasses.Field) -> Any:
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return None


def from_dict(
    cls: type[T], data: dict[str, Any], where: str | None = None, *, key: str = "", base: T | None = None
) -> T:
    """Build a frozen config from a plain dict, refusing unknown keys with the known ones listed.

    A field annotated with a config class (``population: PopulationConfig``) is built from a
    nested table, recursively. A nested table changes only the keys it names: the others keep the
    field's default (so ``[layers.craters.population] k = 2`` keeps the default ``c``).
    ``base`` is such a starting value for the whole of ``cls``.

    ``where`` names the place the dict came from (a file) and ``key`` the dotted path of the table
    in it (``layers.craters``); errors name both, e.g. ``unknown key layers.craters.population.kk``.
    """
    place = ": ".join(p for p in (where, key) if p) or cls.__name__
    if not isinstance(data, dict):
        raise InputError(f"{place}: expected a table of settings, got {type(data).__name__}")
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(data) - set(fields))
    if unknown:
        dotted = ", ".join(f"{key}.{k}" if key else k for k in unknown)
        raise InputError(
            f"{where or cls.__name__}: unknown key(s) {dotted}; known keys{' of ' + key if key else ''}: "
            f"{', '.join(sorted(fields))}{did_you_mean(unknown, fields)}"
        )
    hints = typing.get_type_hints(cls)
    kwargs: dict[str, Any] = {}
    for name, value in data.items():
        sub = dataclass_type(hints.get(name, Any))
        dotted = f"{key}.{name}" if key else name
        if sub is not None and isinstance(value, dict):
            start = getattr(base, name) if base is not None else _field_default(fields[name])
            kwargs[name] = from_dict(sub, value, where, key=dotted, base=start if isinstance(start, sub) else None)
        elif sub is not None and value is not None and not isinstance(value, sub):
            raise InputError(f"{where or cls.__name__}: {dotted} must be a table of {sub.__name__} settings, got {value!r}")
        else:
            kwargs[name] = _coerce(value, hints.get(name, Any), name)
    try:
        if base is not None:
            return dataclasses.replace(base, **kwargs)
        return cls(**kwargs)
    except TypeError as exc:  # e.g. a missing required field
        raise InputError(f"{place}: {exc}") from None
    except InputError as exc:
        if where is None and not key:
            raise
        msg = str(exc)
        if key and msg.startswith(f"{cls.__name__}."):  # "PopulationConfig.k = 9 ..." -> "layers.craters.population.k = 9 ..."
            msg = key + msg[len(cls.__name__) :]
        raise InputError(f"{where}: {msg}" if where else msg) from None


def to_dict(cfg: Any) -> dict[str, Any]:
    """A JSON/TOML-friendly dict of a config (tuples become lists)."""

    def plain(v: Any) -> Any:
        if dataclasses.is_dataclass(v) and not isinstance(v, type):
            return {f.name: plain(getattr(v, f.name)) for f in dataclasses.fields(v)}
        if isinstance(v, (tuple, list)):
            return [plain(x) for x in v]
        if isinstance(v, dict):
            return {k: plain(x) for k, x in v.items()}
        return v

    return plain(cfg)


def config_id(obj: Any, seed: int | None = None, length: int = 12) -> str:
    """A stable short hash of a config (or any plain data) plus a seed: same input, same id."""
    payload = json.dumps({"cfg": to_dict(obj), "seed": seed}, sort_keys=True, default=repr)
    return hashlib.sha256(payload.encode()).hexdigest()[:length]


def load_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file; a missing file or a syntax error becomes an InputError naming the file."""
    from offroadbench.io.inputs import check_input_file

    p = check_input_file(path, "TOML file")
    try:
        with p.open("rb") as fh:
            return tomllib.load(fh)
    except OSError as exc:
        raise InputError(f"TOML file {p}: cannot be read ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise InputError(f"TOML file {p}: not valid TOML (not UTF-8 text)") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"TOML file {p}: not valid TOML ({exc})") from None
    except RecursionError:
        raise InputError(f"TOML file {p}: nested too deeply to be a recipe or study") from None


def parse_set_value(text: str) -> Any:
    """Parse the value part of ``--set key=value`` as a TOML value, falling back to a string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def set_dotted(data: dict[str, Any], dotted_key: str, value: Any) -> dict[str, Any]:
    """Return a deep copy of ``data`` with ``a.b.c`` set to ``value``.

    Missing tables on the path are created (``layers.craters.stamp.roughness`` works on a recipe
    that leaves ``stamp`` at its defaults); the config loader then refuses a key or table that
    does not exist, naming its full dotted path. A value that is not a table cannot hold a key.
    """
    import copy

    out = copy.deepcopy(data)
    parts = dotted_key.split(".")
    if not all(parts):
        raise InputError(f"--set {dotted_key}: not a dotted key (a.b.c)")
    node = out
    for i, part in enumerate(parts[:-1]):
        child = node.setdefault(part, {})
        if not isinstance(child, dict):
            here = ".".join(parts[: i + 1])
            raise InputError(f"--set {dotted_key}: {here} is a value ({child!r}), not a table")
        node = child
    node[parts[-1]] = value
    return out
