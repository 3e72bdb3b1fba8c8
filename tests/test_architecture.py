"""The package's shape: side effects at the edges, no import cycles, physics engines only behind
the engine boundary (offroadbench.sim.engine)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "offroadbench"


def _modules() -> dict[str, Path]:
    out = {}
    for path in PKG.rglob("*.py"):
        rel = path.relative_to(PKG.parent).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _imported_names(node: ast.AST, package: str) -> list[str]:
    """The absolute dotted names an ``Import``/``ImportFrom`` node imports (``from a import b``
    gives ``a.b`` and ``a``; relative imports resolved against ``package``); [] for other nodes."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    if isinstance(node, ast.ImportFrom):
        base = node.module or ""
        if node.level:
            anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
            base = ".".join([*anchor, base] if base else anchor)
        return [f"{base}.{a.name}" for a in node.names] + [base]
    return []


def _top_level_imports(path: Path, module: str, known: set[str]) -> set[str]:
    """offroadbench modules imported at module level (not inside functions or TYPE_CHECKING)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    found: set[str] = set()
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]

    def resolve(name: str) -> str | None:
        while name and name not in known:
            name = name.rpartition(".")[0]
        return name or None

    for node in tree.body:
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            continue
        stmts = [node] if not isinstance(node, (ast.Try, ast.If)) else [*node.body]
        for st in stmts:
            for n in _imported_names(st, package):
                if n.startswith("offroadbench"):
                    r = resolve(n)
                    if r and r != module:
                        found.add(r)
    return found


def test_no_module_level_import_cycles():
    mods = _modules()
    graph = {m: _top_level_imports(p, m, set(mods)) for m, p in mods.items()}
    # a package's __init__ importing its own submodules is not a cycle of concern; edges from a
    # submodule back to its parent package are (they re-enter a half-initialised package)
    state: dict[str, int] = {}
    stack: list[str] = []
    cycles: list[list[str]] = []

    def visit(m: str) -> None:
        state[m] = 1
        stack.append(m)
        for n in sorted(graph.get(m, ())):
            if m.startswith(n + "."):
                continue  # submodule -> its own parent package: importing the parent is already under way
            if state.get(n) == 1:
                cycles.append(stack[stack.index(n):] + [n])
            elif n not in state:
                visit(n)
        stack.pop()
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m)
    assert not cycles, "module-level import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


@pytest.mark.parametrize("module", ["offroadbench.study", "offroadbench.sim.config", "offroadbench.study.spec.config",
                                    "offroadbench.terrain", "offroadbench.navigation.planners",
                                    "offroadbench.study.report.markdown", "offroadbench.plots.study"])
def test_importing_leaves_pybullet_and_matplotlib_backend_alone(module):
    code = (
        "import sys, matplotlib\n"
        "before = matplotlib.rcParams._get_backend_or_none()\n"
        f"import {module}\n"
        "assert 'pybullet' not in sys.modules, 'pybullet imported'\n"
        "assert 'matplotlib.pyplot' not in sys.modules, 'pyplot imported'\n"
        "assert matplotlib.rcParams._get_backend_or_none() == before, 'backend changed'\n"
    )
    env = {k: v for k, v in __import__("os").environ.items() if k != "MPLBACKEND"}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr


#: top-level packages of physics engines -> the engine they belong to
ENGINE_PACKAGES = {"pybullet": "pybullet", "pybullet_data": "pybullet", "pybullet_envs": "pybullet", "mujoco": "mujoco",
                   "mujoco_warp": "mujoco_warp", "warp": "mujoco_warp"}
#: engine packages that may also talk to another engine: the batched MuJoCo Warp engine compiles its
#: model with MuJoCo (the MuJoCo engine's model, offroadbench.sim.engines.mujoco_warp.model)
ENGINE_ALSO = {"mujoco_warp": {"mujoco"}}
#: modules outside the engine packages that may import an engine: the banner guard (it imports
#: pybullet quietly for the CLI and the study workers)
ENGINE_EXCEPTIONS = {"offroadbench.sim._banner": {"pybullet"}}


def _engine_uses(tree: ast.AST) -> list[tuple[str, str]]:
    """Every place in ``tree`` that talks to a physics engine directly, at any level (inside
    functions too), as (engine, where and what): an import of an engine package (statement,
    ``importlib.import_module`` or ``__import__`` of a literal name), a PyBullet client id
    (``.client_id``, ``physicsClientId=``)."""
    found = []
    for node in ast.walk(tree):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level:
            names = [node.module or ""]
        elif isinstance(node, ast.Call):
            func = node.func
            fname = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if fname in ("import_module", "__import__") and node.args and isinstance(node.args[0], ast.Constant):
                names = [str(node.args[0].value)]
            found += [("pybullet", f"line {node.lineno}: physicsClientId=") for k in node.keywords
                      if k.arg == "physicsClientId"]
        elif isinstance(node, ast.Attribute) and node.attr == "client_id":
            found.append(("pybullet", f"line {node.lineno}: .client_id"))
        found += [(ENGINE_PACKAGES[n.split(".")[0]], f"line {node.lineno}: imports {n}") for n in names
                  if n.split(".")[0] in ENGINE_PACKAGES]
    return found


def _allowed_engines(module: str) -> set[str]:
    """The engines ``module`` may talk to: its own, inside ``offroadbench.sim.engines.<engine>``."""
    parts = module.split(".")
    if parts[:3] == ["offroadbench", "sim", "engines"] and len(parts) > 3 and parts[3] in ENGINE_PACKAGES.values():
        return {parts[3]} | ENGINE_ALSO.get(parts[3], set())
    return ENGINE_EXCEPTIONS.get(module, set())


def test_the_engine_detector_sees_function_level_imports_and_client_ids():
    code = (
        "import numpy\n"
        "def f(world):\n"
        "    import pybullet as pb\n"
        "    from mujoco import MjModel\n"
        "    importlib.import_module('pybullet_data')\n"
        "    return pb.getAABB(world.vehicle_id, physicsClientId=world.client_id)\n"
    )
    found = _engine_uses(ast.parse(code))
    assert {(e, f.split(": ", 1)[1]) for e, f in found} == {
        ("pybullet", "imports pybullet"), ("mujoco", "imports mujoco"), ("pybullet", "imports pybullet_data"),
        ("pybullet", "physicsClientId="), ("pybullet", ".client_id")}
    assert _engine_uses(ast.parse("import numpy\nfrom offroadbench.sim import engine\n")) == []
    assert _allowed_engines("offroadbench.sim.engines.mujoco.world") == {"mujoco"}
    assert _allowed_engines("offroadbench.sim.engines.base") == set()
    assert _allowed_engines("offroadbench.sim.rigs.soil_check") == set()


def test_only_each_engine_package_talks_to_its_engine():
    """The engine boundary (issues 19, 35): only modules under ``sim/engines/pybullet/`` import
    pybullet or use a physics client id, only modules under ``sim/engines/mujoco/`` import mujoco
    (and ``sim/engines/mujoco_warp/``, which also compiles its model with it), only those under
    ``sim/engines/mujoco_warp/`` import mujoco_warp or warp (the banner guard aside), at any level; and each engine package does talk to its engine (the
    rule is not vacuous)."""
    offenders = []
    used: dict[str, set[str]] = {}
    for m, path in _modules().items():
        uses = _engine_uses(ast.parse(path.read_text()))
        allowed = _allowed_engines(m)
        offenders += [f"{m}: {what}" for engine, what in uses if engine not in allowed]
        for engine, _ in uses:
            used.setdefault(engine, set()).add(m)
    assert offenders == []
    assert {m.split(".")[3] for e in used for m in used[e] if m.startswith("offroadbench.sim.engines.")} == {
        "pybullet", "mujoco", "mujoco_warp"}


def test_print_only_in_cli():
    for m, path in _modules().items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "print":
                assert m.startswith("offroadbench.cli"), f"{m} calls print()"


def test_io_does_not_import_terrain():
    """Files are read at the edge (recipe loading calls io) and io knows file formats only, so
    the dependency runs terrain -> io and never back (no terrain <-> io cycle, even in functions)."""
    offenders = []
    for path in (PKG / "io").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else []
            if isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            offenders += [f"{path.relative_to(PKG)}: {n}" for n in names if n.startswith("offroadbench.terrain")]
    assert offenders == []


def _all_imports(path: Path, module: str, known: set[str]) -> set[str]:
    """offroadbench modules ``module`` imports anywhere in its file: at module level and inside
    functions, methods and conditionals (every ``Import``/``ImportFrom`` node at any depth, except
    under ``if TYPE_CHECKING``). Importing ``a.b.c`` also runs the packages ``a.b`` and ``a`` first,
    so those count as imported too. Registries' loaders, which import their built-ins by name
    (``importlib.import_module("...")``) the first time a registry is read, are not imports here."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]

    def resolve(name: str) -> str | None:
        while name and name not in known:
            name = name.rpartition(".")[0]
        return name or None

    found: set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for child in node.orelse:
                visit(child)
            return
        for n in _imported_names(node, package):
            r = resolve(n) if n.startswith("offroadbench") else None
            while r and r != module:
                found.add(r)
                r = r.rpartition(".")[0] if "." in r else None  # its parent packages run first
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(ast.parse(path.read_text(), filename=str(path)))
    found.discard(module)
    return found


def test_no_import_cycles_at_any_level():
    """No cycle among the package's modules counting every import, also those inside functions
    (a function-level import hides a cycle until the function runs, and lets two modules grow into
    one). A module importing its own parent package is not an edge (the parent is already being
    imported)."""
    mods = _modules()
    graph = {m: {n for n in _all_imports(p, m, set(mods)) if not m.startswith(n + ".")} for m, p in mods.items()}
    # Tarjan's strongly connected components: every cycle lies inside one of more than one module
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def strongconnect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                strongconnect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                components.append(sorted(comp))

    for m in sorted(graph):
        if m not in index:
            strongconnect(m)
    detail = [", ".join(c) + ":\n  " + "\n  ".join(f"{a} -> {', '.join(sorted(graph[a] & set(c)))}" for a in c)
              for c in components]
    assert not components, "import cycles (counting imports inside functions):\n" + "\n".join(detail)


def test_the_any_level_cycle_check_sees_imports_inside_functions(tmp_path):
    """The check above is not vacuous: a cycle closed only by an import inside a function is found."""
    pkg = tmp_path / "offroadbench"
    pkg.mkdir()
    (pkg / "a.py").write_text("from offroadbench import b\n")
    (pkg / "b.py").write_text("def f():\n    if True:\n        from offroadbench.a import x\n")
    known = {"offroadbench", "offroadbench.a", "offroadbench.b"}
    assert _top_level_imports(pkg / "b.py", "offroadbench.b", known) == set()
    assert _all_imports(pkg / "b.py", "offroadbench.b", known) == {"offroadbench.a", "offroadbench"}


def test_layers_point_one_way():
    """Figures draw what they are given (plots imports nothing of study; the report imports
    plots), export writes files (io imports nothing of analysis; the CLI warns about a spike),
    and no package imports another's private module (e.g. study -> sim._banner)."""
    mods = _modules()
    known = set(mods)
    offenders = []
    for m, p in mods.items():
        imported = _all_imports(p, m, known)
        if m.startswith("offroadbench.plots"):
            offenders += [f"{m} -> {n}" for n in imported if n.startswith("offroadbench.study")]
        if m.startswith("offroadbench.io"):
            offenders += [f"{m} -> {n}" for n in imported if n.startswith("offroadbench.analysis")]
        for n in imported:
            private = next((part for part in n.split(".")[1:] if part.startswith("_") and part != "__init__"), None)
            owner = n[: n.index("." + private)] if private else None
            if private and not (m == owner or m.startswith(owner + ".")):
                offenders.append(f"{m} -> {n} (private to {owner})")
    assert offenders == []


#: the most lines a module of the package may have: above it a module does more than one job
MAX_MODULE_LINES = 500


def _long_modules(root: Path, limit: int) -> list[str]:
    return sorted(f"{p.relative_to(root.parent)}: {n} lines" for p in root.rglob("*.py")
                  if (n := len(p.read_text().splitlines())) > limit)


def test_no_module_over_500_lines():
    """Each module does one job: one over the limit is split along the jobs it does (issue 35)."""
    assert _long_modules(PKG, MAX_MODULE_LINES) == []


def test_the_module_length_check_sees_a_long_module(tmp_path):
    """The check above is not vacuous: a module one line over the limit is named, one at it is not."""
    pkg = tmp_path / "offroadbench"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "sub" / "long.py").write_text("x = 1\n" * (MAX_MODULE_LINES + 1))
    (pkg / "ok.py").write_text("x = 1\n" * MAX_MODULE_LINES)
    assert _long_modules(pkg, MAX_MODULE_LINES) == [f"offroadbench/sub/long.py: {MAX_MODULE_LINES + 1} lines"]


#: the storage package: the only place in the package that talks SQL (issue 43)
STORE_PACKAGE = "offroadbench.study.store"
_SQL = __import__("re").compile(r"^\s*(SELECT|INSERT|UPDATE|DELETE|CREATE|ALTER|DROP|PRAGMA|BEGIN|COMMIT|ROLLBACK)\b")


def _sql_uses(tree: ast.AST) -> list[str]:
    """Where ``tree`` talks SQL: imports sqlite3, calls ``execute``/``executemany``/``executescript``,
    or holds a string that starts with an SQL statement."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import) and any(a.name == "sqlite3" for a in node.names):
            found.append(f"line {node.lineno}: imports sqlite3")
        elif isinstance(node, ast.ImportFrom) and node.module == "sqlite3":
            found.append(f"line {node.lineno}: imports sqlite3")
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in (
                "execute", "executemany", "executescript"):
            found.append(f"line {node.lineno}: .{node.func.attr}()")
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and _SQL.match(node.value):
            found.append(f"line {node.lineno}: SQL text {node.value.strip()[:30]!r}")
    return found


def test_sql_only_in_the_store_package():
    """Every table of a run directory is read and written through the store's own functions: no
    module outside offroadbench.study.store talks SQL (the search's table included)."""
    offenders = [f"{m}: {what}" for m, path in _modules().items()
                 if not (m == STORE_PACKAGE or m.startswith(STORE_PACKAGE + "."))
                 for what in _sql_uses(ast.parse(path.read_text()))]
    assert offenders == []


def test_the_sql_check_sees_sql():
    code = ("import sqlite3\n"
            "def f(store):\n"
            "    store.con.execute('SELECT 1')\n"
            "    q = '''\n    CREATE TABLE IF NOT EXISTS t (a);'''\n")
    assert {w.split(": ", 1)[1] for w in _sql_uses(ast.parse(code))} == {
        "imports sqlite3", ".execute()", "SQL text 'SELECT 1'", "SQL text 'CREATE TABLE IF NOT EXISTS t ('"}
    assert _sql_uses(ast.parse("x = 'Select the cells'\nprint('selects')\n")) == []


def _private_names_imported(tree: ast.AST, module: str, package: str, known: set[str]) -> list[str]:
    """Private names (``_x``, not dunders and not submodules) that ``module`` imports from another
    module, at any level: ``from offroadbench.a import _helper`` in ``offroadbench.b``."""
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.ImportFrom):
            continue
        base = node.module or ""
        if node.level:
            anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
            base = ".".join([*anchor, base] if base else anchor)
        if not base.startswith("offroadbench") or base == module:
            continue
        found += [f"{module} imports {base}.{a.name}" for a in node.names
                  if a.name.startswith("_") and not a.name.startswith("__") and f"{base}.{a.name}" not in known]
    return found


def test_no_module_imports_another_modules_private_name():
    """What one module lets others use is public (and exported by its package's ``__init__`` where
    others outside the package use it); a private name is the module's own (issue 43)."""
    mods = _modules()
    offenders = []
    for m, p in mods.items():
        package = m if p.name == "__init__.py" else m.rpartition(".")[0]
        offenders += _private_names_imported(ast.parse(p.read_text()), m, package, set(mods))
    assert offenders == []


def test_the_private_name_check_sees_private_names():
    known = {"offroadbench", "offroadbench.a", "offroadbench.a._impl", "offroadbench.b"}
    code = ("from offroadbench.a import _helper, public, __version__, _impl\n"
            "def f():\n    from .a import _other\n")
    assert _private_names_imported(ast.parse(code), "offroadbench.b", "offroadbench", known) == [
        "offroadbench.b imports offroadbench.a._helper", "offroadbench.b imports offroadbench.a._other"]
    assert _private_names_imported(ast.parse("from offroadbench.b import _x\n"), "offroadbench.b", "offroadbench",
                                   known) == []
