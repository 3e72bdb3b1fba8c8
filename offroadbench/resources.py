"""Where presets, vehicles, study files and sample data live: the one place that knows.

offroadbench ships its data inside the package, found with :mod:`importlib.resources`, so an
installed wheel works from any directory:

* ``offroadbench.data.terrains``: terrain presets (``<name>.toml``) and ``data/sample-dem.npy``;
* ``offroadbench.data.vehicles``: one folder per vehicle, holding ``vehicle.toml`` and its URDF;
* ``offroadbench.data.experiments``: study TOMLs (``smoke.toml``, ``majhor2023.toml``, ...);
* ``offroadbench.data.soils``: soil parameter sets (``<name>.toml``, offroadbench.sim.tyre_laws.terramechanics);
* ``offroadbench.data.suites``: task suites (``<name>.toml``, offroadbench.suite) and the shipped
  baselines' score cards (``scores/<suite>/<tier>/<planner>/score.json``).

In the repository these are the top-level folders ``terrains/``, ``vehicles/``,
``experiments/``, ``soils/`` and ``suites/``; ``setup.py`` maps them into the package at build time (editable installs too).

**Search path.** The environment variable ``OFFROADBENCH_PATH`` adds user folders: a list of
directories separated by ``os.pathsep`` (``:`` on Linux and macOS, ``;`` on Windows), each holding
any of ``terrains/``, ``vehicles/``, ``experiments/`` and ``soils/`` laid out like the shipped ones. They are
searched in order, before the shipped data, and the first folder holding a name wins, so a user
preset can replace a shipped one of the same name. The variable is read on every lookup.
"""

from __future__ import annotations

import os
from importlib import resources as _ir
from pathlib import Path

from offroadbench.errors import InputError

__all__ = [
    "ENV_VAR",
    "KINDS",
    "search_path",
    "shipped",
    "roots",
    "terrain_presets",
    "vehicle_files",
    "study_files",
    "soil_files",
    "suite_files",
    "suite_scores_dir",
    "sample_dem",
    "matplotlib_sample",
    "package_dir",
]

#: environment variable holding the user search path (os.pathsep-separated directories)
ENV_VAR = "OFFROADBENCH_PATH"
#: the kinds of data, each a sub-folder of a search-path directory and a package under offroadbench.data
KINDS = ("terrains", "vehicles", "experiments", "soils", "suites")


def _as_path(resource, what: str) -> Path:
    """A file-system path for a resource (offroadbench must be installed as files, not zipped)."""
    if isinstance(resource, Path):
        return resource
    raise RuntimeError(f"{what} is not on the file system ({resource!r}); install offroadbench unzipped")


def package_dir() -> Path:
    """The folder of the imported ``offroadbench`` package (site-packages, or the checkout)."""
    return _as_path(_ir.files("offroadbench"), "the offroadbench package")


def shipped(kind: str) -> Path:
    """The folder of data of ``kind`` shipped inside the package."""
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    try:
        res = _ir.files(f"offroadbench.data.{kind}")
    except ModuleNotFoundError:
        raise RuntimeError(
            f"offroadbench.data.{kind} is missing: this installation predates the packaged data; "
            "reinstall offroadbench (pip install -e . in a checkout)"
        ) from None
    return _as_path(res, f"offroadbench.data.{kind}")


def search_path() -> list[Path]:
    """The user directories of ``$OFFROADBENCH_PATH``, in order; each must be an existing directory."""
    out = []
    for entry in os.environ.get(ENV_VAR, "").split(os.pathsep):
        if not entry.strip():
            continue
        p = Path(entry).expanduser()
        if not p.is_dir():
            raise InputError(f"{ENV_VAR}: {entry!r} is not a directory; give directories holding terrains/ or vehicles/")
        out.append(p)
    return out


def roots(kind: str) -> list[Path]:
    """Folders searched for data of ``kind``, first match wins: the search path's, then the shipped one."""
    user = [d / kind for d in search_path() if (d / kind).is_dir()]
    return [*user, shipped(kind)]


def _first_found(kind: str, pattern: str) -> dict[str, Path]:
    """{name: path} over :func:`roots`; a name is the stem of a file, or the folder of ``*/file``."""
    out: dict[str, Path] = {}
    for root in roots(kind):
        for p in sorted(root.glob(pattern)):
            name = p.parent.name if "/" in pattern else p.stem
            out.setdefault(name, p)
    return dict(sorted(out.items()))


def terrain_presets() -> dict[str, Path]:
    """{preset name: TOML path} of every ``terrains/<name>.toml`` on the search path and shipped."""
    return _first_found("terrains", "*.toml")


def vehicle_files() -> dict[str, Path]:
    """{vehicle name: path of its vehicle.toml} of every ``vehicles/<name>/vehicle.toml``."""
    return _first_found("vehicles", "*/vehicle.toml")


def study_files() -> dict[str, Path]:
    """{study name: TOML path} of every ``experiments/<name>.toml`` (``smoke``, ``majhor2023``, ...)."""
    return _first_found("experiments", "*.toml")


def soil_files() -> dict[str, Path]:
    """{soil name: TOML path} of every ``soils/<name>.toml`` (``lunar-regolith``, ``lete-sand``, ...)."""
    return _first_found("soils", "*.toml")


def suite_files() -> dict[str, Path]:
    """{suite name: TOML path} of every ``suites/<name>.toml`` (``offroadbench-v1``, ...)."""
    return _first_found("suites", "*.toml")


def suite_scores_dir() -> Path:
    """The shipped folder of the baselines' committed score cards, ``suites/scores``."""
    return shipped("suites") / "scores"


def matplotlib_sample(name: str) -> Path:
    """A sample data file shipped inside matplotlib (e.g. ``jacksboro_fault_dem.npz``, a real DEM)."""
    from matplotlib import get_data_path

    p = Path(get_data_path()) / "sample_data" / name
    if not p.is_file():
        raise InputError(f"matplotlib:{name}: matplotlib ships no such sample file (in {p.parent})")
    return p


def sample_dem() -> Path:
    """The shipped synthetic sample DEM with gaps (``terrains/data/sample-dem.npy`` + its JSON sidecar)."""
    return shipped("terrains") / "data" / "sample-dem.npy"
