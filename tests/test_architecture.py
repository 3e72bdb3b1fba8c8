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
            if isinstance(st, ast.Import):
                names = [a.name for a in st.names]
            elif isinstance(st, ast.ImportFrom):
                base = st.module or ""
                if st.level:
                    anchor = package.split(".")[: len(package.split(".")) - st.level + 1]
                    base = ".".join([*anchor, base] if base else anchor)
                names = [f"{base}.{a.name}" for a in st.names] + [base]
            else:
                continue
            for n in names:
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


@pytest.mark.parametrize("module", ["offroadbench.study", "offroadbench.sim.config", "offroadbench.study.spec",
                                    "offroadbench.terrain", "offroadbench.navigation.planners",
                                    "offroadbench.study.report", "offroadbench.plots.study"])
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


#: the only modules that may talk to a physics engine (offroadbench.sim.engine, the engine boundary)
ENGINE_MODULES = {"offroadbench.sim.world", "offroadbench.sim.contact", "offroadbench.sim._banner",
                  "offroadbench.sim.mujoco_world"}
#: top-level packages of physics engines
ENGINE_PACKAGES = {"pybullet", "pybullet_data", "pybullet_envs", "mujoco"}


def _engine_uses(tree: ast.AST) -> list[str]:
    """Every place in ``tree`` that talks to a physics engine directly, at any level (inside
    functions too): an import of an engine package (statement, ``importlib.import_module`` or
    ``__import__`` of a literal name), a physics client id (``.client_id``, ``physicsClientId=``)."""
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
            found += [f"line {node.lineno}: physicsClientId=" for k in node.keywords if k.arg == "physicsClientId"]
        elif isinstance(node, ast.Attribute) and node.attr == "client_id":
            found.append(f"line {node.lineno}: .client_id")
        found += [f"line {node.lineno}: imports {n}" for n in names if n.split(".")[0] in ENGINE_PACKAGES]
    return found


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
    assert {f.split(": ", 1)[1] for f in found} == {
        "imports pybullet", "imports mujoco", "imports pybullet_data", "physicsClientId=", ".client_id"}
    assert _engine_uses(ast.parse("import numpy\nfrom offroadbench.sim import engine\n")) == []


def test_only_the_engine_modules_talk_to_an_engine():
    """The engine boundary (issue 19): no module but sim/world.py, sim/contact.py, the banner guard
    and the MuJoCo world imports pybullet or mujoco or uses a physics client id, at any level."""
    offenders = []
    for m, path in _modules().items():
        if m not in ENGINE_MODULES:
            offenders += [f"{m}: {f}" for f in _engine_uses(ast.parse(path.read_text()))]
    assert offenders == []


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
