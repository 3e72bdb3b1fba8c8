"""The settings reference, read from the source: a config's field docstrings (with units), types,
defaults and the allowed ranges of its ``__post_init__`` checks (see offroadbench.reference)."""

from __future__ import annotations

import ast
import dataclasses
import inspect
import itertools
import sys
import textwrap
import types
import typing
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any


#: unit of a field from the end of its name (longest suffix first)
_UNITS = (
    ("_n_s_m", "N s/m"), ("_kg_m2", "kg m^2"), ("_rad_s", "rad/s"), ("_deg_s", "deg/s"), ("_m_s3", "m/s^3"),
    ("_m_s2", "m/s^2"), ("_m_s", "m/s"), ("_n_m", "N/m"), ("_nm", "N m"), ("_1_m", "1/m"), ("_hz", "Hz"),
    ("_deg", "deg"), ("_rad", "rad"), ("_pct", "%"), ("_mm", "mm"), ("_m", "m"), ("_s", "s"),
)


def unit_of(name: str) -> str:
    """The SI unit a field or column name carries in its suffix (``lookahead_m`` -> ``m``), or ''."""
    for suffix, unit in _UNITS:
        if name.endswith(suffix):
            return unit
    return ""


@dataclass(frozen=True)
class FieldDoc:
    """One key of a settings table (or one column of a table)."""

    name: str
    type: str
    default: Any
    """The default value; :data:`REQUIRED` when the key must be given."""
    unit: str
    allowed: str
    doc: str


@dataclass(frozen=True)
class SectionDoc:
    """One table of a study TOML: its keys and where they come from."""

    name: str
    source: str
    summary: str
    fields: tuple[FieldDoc, ...]
    notes: tuple[str, ...] = ()
    generator: str = ""
    """For a recipe layer's tables: the generator or modifier they belong to."""


REQUIRED = object()


# ---------------------------------------------------------------------------- reading the source
def _class_tree(cls: type) -> ast.ClassDef | None:
    try:
        src = textwrap.dedent(inspect.getsource(cls))
    except (OSError, TypeError):
        return None
    for node in ast.parse(src).body:
        if isinstance(node, ast.ClassDef):
            return node
    return None


def _attribute_docs(cls: type) -> dict[str, str]:
    """{field: docstring} of the string literals that follow each annotated field, over the MRO."""
    out: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        tree = _class_tree(klass) if dataclasses.is_dataclass(klass) else None
        if tree is None:
            continue
        body = tree.body
        for a, b in itertools.pairwise(body):
            if (isinstance(a, ast.AnnAssign) and isinstance(a.target, ast.Name) and isinstance(b, ast.Expr)
                    and isinstance(b.value, ast.Constant) and isinstance(b.value.value, str)):
                out[a.target.id] = " ".join(inspect.cleandoc(b.value.value).split())
    return out


def _expr_text(node: ast.AST, module: types.ModuleType, env: dict[str, Any]) -> Any:
    """A keyword argument of a check call as a value (constants, module constants) or as text."""
    try:
        return ast.literal_eval(node)
    except ValueError:
        pass
    if isinstance(node, ast.Name):
        if node.id in env:
            return env[node.id]
        if hasattr(module, node.id):
            return getattr(module, node.id)
    text = ast.unparse(node)
    return text.replace("self.", "")


def _fmt_num(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:g}"
    return str(v)


def _range_text(call: ast.Call, module: types.ModuleType, env: dict[str, Any]) -> tuple[str, str] | None:
    """(field, allowed) of a ``check_range`` / ``check_int`` / ``check_choice`` call, or None."""
    fn = call.func.id if isinstance(call.func, ast.Name) else getattr(call.func, "attr", "")
    if fn not in ("check_range", "check_int", "check_choice") or len(call.args) < 3:
        return None
    field = _expr_text(call.args[1], module, env)
    if not isinstance(field, str):
        return None
    if fn == "check_choice":
        choices = _expr_text(call.args[3], module, env) if len(call.args) > 3 else "?"
        if isinstance(choices, (tuple, list, set, frozenset)):
            choices = ", ".join(f'"{c}"' for c in choices)
        return field, f"one of {choices}"
    kw = {k.arg: _expr_text(k.value, module, env) for k in call.keywords}
    for i, key in enumerate(("lo", "hi"), start=3):
        if len(call.args) > i:
            kw[key] = _expr_text(call.args[i], module, env)
    lo, hi = kw.get("lo"), kw.get("hi")
    if fn == "check_int":
        return field, f"integer {_fmt_num(lo) if lo is not None else '-inf'} .. {_fmt_num(hi) if hi is not None else 'inf'}"
    left = "(" if kw.get("lo_open") or lo is None else "["
    right = ")" if kw.get("hi_open") or hi is None else "]"
    return field, f"{left}{_fmt_num(lo) if lo is not None else '-inf'}, {_fmt_num(hi) if hi is not None else 'inf'}{right}"


def _walk_checks(stmts: list[ast.stmt], module: types.ModuleType, env: dict[str, Any]) -> Iterator[tuple[str, str]]:
    for st in stmts:
        if isinstance(st, ast.For) and isinstance(st.target, ast.Name):
            try:
                values = ast.literal_eval(st.iter)
            except ValueError:
                values = None
            if isinstance(values, (tuple, list)):
                for v in values:
                    yield from _walk_checks(st.body, module, {**env, st.target.id: v})
            else:  # a loop over a field's items: the checks inside name the enclosing field
                yield from _walk_checks(st.body, module, env)
        elif isinstance(st, ast.If):
            yield from _walk_checks(st.body, module, env)
        elif isinstance(st, ast.Expr) and isinstance(st.value, ast.Call):
            got = _range_text(st.value, module, env)
            if got:
                yield got


def _allowed_ranges(cls: type) -> dict[str, str]:
    """{field: allowed values} read from the ``__post_init__`` checks of ``cls`` and its bases."""
    out: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        tree = _class_tree(klass) if dataclasses.is_dataclass(klass) else None
        if tree is None:
            continue
        module = sys.modules[klass.__module__]
        for node in tree.body:
            if isinstance(node, ast.FunctionDef) and node.name == "__post_init__":
                for field, allowed in _walk_checks(node.body, module, {}):
                    out.setdefault(field, allowed) if field in out else out.__setitem__(field, allowed)
    return out


def _type_text(annotation: Any) -> str:
    if annotation in (int, float, str, bool):
        return annotation.__name__
    origin = typing.get_origin(annotation)
    if origin in (types.UnionType, typing.Union):
        return " | ".join("None" if a is type(None) else _type_text(a) for a in typing.get_args(annotation))
    if origin is tuple:
        args = typing.get_args(annotation)
        if len(args) == 2 and args[1] is Ellipsis:
            return f"list of {_type_text(args[0])}"
        return "list"
    if origin is not None:
        return getattr(origin, "__name__", str(annotation))
    return getattr(annotation, "__name__", str(annotation))


def field_docs(cls: type, *, skip: tuple[str, ...] = (), defaults: Any = None) -> tuple[FieldDoc, ...]:
    """The keys of config class ``cls``, in declaration order. ``defaults``: an instance whose values
    stand as the defaults (a vehicle's own values)."""
    from offroadbench.bounds import BOUNDS

    docs = _attribute_docs(cls)
    ranges = _allowed_ranges(cls)
    for name, bound in BOUNDS.get(cls.__name__, {}).items():  # physical bounds (sources: "Physical bounds")
        ranges[name] = f"{ranges[name]}; physically {bound.text()}" if ranges.get(name) else f"physically {bound.text()}"
    hints = typing.get_type_hints(cls)
    out = []
    for f in dataclasses.fields(cls):
        if not f.init or f.name in skip:
            continue
        if defaults is not None:
            default = getattr(defaults, f.name)
        elif f.default is not dataclasses.MISSING:
            default = f.default
        elif f.default_factory is not dataclasses.MISSING:
            default = f.default_factory()
        else:
            default = REQUIRED
        out.append(FieldDoc(f.name, _type_text(hints.get(f.name, Any)), default, unit_of(f.name),
                            ranges.get(f.name, ""), docs.get(f.name, "")))
    return tuple(out)


def qualname(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def first_line(obj: Any) -> str:
    doc = inspect.getdoc(obj) or ""
    return " ".join(doc.split("\n\n")[0].split())
