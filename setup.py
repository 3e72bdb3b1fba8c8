"""Package layout for setuptools; the metadata lives in pyproject.toml.

The data folders stay at the top of the repository (``terrains/``, ``vehicles/``, ``experiments/``, ``soils/``, ``suites/``)
and are mapped into the package as ``offroadbench.data.<folder>``, so an installed wheel carries
them and ``offroadbench.resources`` finds them with ``importlib.resources`` in an editable install
too. This file only exists because ``pyproject.toml`` cannot combine package discovery with such a
mapping; it computes the package list from the folders, so a new vehicle needs no edit here.
"""

from setuptools import find_namespace_packages, find_packages, setup

#: top-level folder -> file patterns shipped from it and from each of its sub-folders
DATA = {
    "terrains": ["*.toml", "*.npy", "*.json", "*.png"],
    "vehicles": ["*.toml", "*.urdf", "*.sdf", "*.xml", "*.obj", "*.stl", "*.dae", "*.png"],
    "experiments": ["*.toml", "*.csv"],  # the study TOMLs and their pilots (experiments/pilots/: a plan's power)
    "soils": ["*.toml", "*.csv"],
    "suites": ["*.toml", "*.json"],  # task suites and the baselines' score cards (scores/)
}
#: sub-folders that stay in the repository (committed study outputs)
KEEP_OUT = {"experiments": ["results", "results.*"]}

packages = find_packages(include=["offroadbench", "offroadbench.*"])
package_dir = {"offroadbench": "offroadbench"}
package_data = {"offroadbench": ["py.typed"], "offroadbench.navigation.policies": ["data/*.npz"]}  # the ppo weights
for folder, patterns in DATA.items():
    root = f"offroadbench.data.{folder}"
    subs = find_namespace_packages(where=folder, exclude=["__pycache__", *KEEP_OUT.get(folder, [])])
    for name in [root, *(f"{root}.{s}" for s in subs)]:
        packages.append(name)
        package_data[name] = patterns
    package_dir[root] = folder

setup(packages=packages, package_dir=package_dir, package_data=package_data)
