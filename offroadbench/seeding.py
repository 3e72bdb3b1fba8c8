"""Every seeding rule of offroadbench, in one place.

All randomness comes from ``np.random.SeedSequence`` (never the global NumPy state). The rules:

* **Layer streams.** A terrain is built from one integer seed (what ``offroadbench generate
  --seed`` takes). Each recipe layer draws from its own stream, a child of ``SeedSequence(seed)``
  keyed by the layer's name (:func:`layer_rng`), so adding, removing or reordering layers never
  changes another layer's random numbers.
* **Terrain j of a root seed.** A run over many terrains (``study run``, ``roughness-study``,
  ``drive``) takes a root seed; terrain j gets the integer seed :func:`terrain_seed` ``(root, j)``,
  the child ``SeedSequence(root, spawn_key=(0, cell, j))`` turned into a 63-bit integer. Every
  table that lists a terrain shows that integer: ``generate --seed <it>`` rebuilds the terrain
  bit for bit.
* **Mission k of terrain j.** :func:`mission_seed` ``(root, j, k)`` is the child
  ``SeedSequence(root, spawn_key=(1, cell, j, k))`` as an integer; the mission is drawn alone from
  :func:`mission_rng` of it, so it does not depend on which other missions are drawn.
* **Cells.** A study's grid cell has a key (:func:`cell_key`): 0 when terrains are paired (terrain
  j of every cell comes from the same seed: common random numbers, so cells differ only by their
  grid values), else a stable hash of the cell's values. ``roughness-study`` pairs its D values and
  ``drive`` is terrain 0 of cell 0, so terrain j of ``roughness-study --seed s`` and of a paired
  study with ``root_seed = s`` are the same terrain, and ``drive --seed s`` drives on terrain 0 of
  such a study, with the same missions.

Every seed is a pure function of (root, stream, cell, terrain[, mission]): the same seed gives the
same terrains and trials whatever the order of execution, the number of workers or a resumption,
and adding terrains or missions never changes the existing ones. (A Gymnasium environment seeds
its episodes through Gymnasium's own ``reset(seed=...)``, as its API requires; its terrain is built
from an integer terrain seed as above.)
"""

from __future__ import annotations

import hashlib
import json
import zlib
from typing import Any, Mapping

import numpy as np

from offroadbench.errors import InputError

__all__ = [
    "TERRAIN_STREAM",
    "MISSION_STREAM",
    "seed_sequence",
    "layer_rng",
    "derive_seed",
    "cell_key",
    "terrain_seed",
    "mission_seed",
    "mission_rng",
]

#: First spawn-key entry of the terrain and mission streams of a root seed.
TERRAIN_STREAM = 0
MISSION_STREAM = 1


def seed_sequence(seed: int | np.random.SeedSequence) -> np.random.SeedSequence:
    """A SeedSequence from an integer seed (>= 0), or the SeedSequence itself."""
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed must be an integer >= 0, got {seed!r}")
    return np.random.SeedSequence(int(seed))


def layer_rng(root: np.random.SeedSequence, layer_name: str) -> np.random.Generator:
    """The random stream of one recipe layer: a child of ``root`` keyed by the layer's name (CRC-32)."""
    key = zlib.crc32(layer_name.encode())
    child = np.random.SeedSequence(entropy=root.entropy, spawn_key=(*root.spawn_key, key))
    return np.random.default_rng(child)


def derive_seed(root_seed: int, *path: int) -> int:
    """The 63-bit integer seed of the child ``SeedSequence(root_seed, spawn_key=path)``."""
    child = np.random.SeedSequence(int(root_seed), spawn_key=tuple(int(p) for p in path))
    return int(child.generate_state(1, np.uint64)[0] >> np.uint64(1))


def cell_key(values: Mapping[str, Any], paired: bool) -> int:
    """Spawn-key entry of a study's grid cell: 0 when paired, else a stable 31-bit hash of its values."""
    if paired:
        return 0
    text = json.dumps(dict(values), sort_keys=True, default=repr)
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:4], "big") >> 1


def terrain_seed(root_seed: int, terrain: int, *, cell: int = 0) -> int:
    """The integer seed of terrain ``terrain`` of ``root_seed`` (of the cell with key ``cell``)."""
    return derive_seed(root_seed, TERRAIN_STREAM, cell, terrain)


def mission_seed(root_seed: int, terrain: int, mission: int, *, cell: int = 0) -> int:
    """The integer seed of mission ``mission`` on terrain ``terrain`` of ``root_seed`` (cell key ``cell``)."""
    return derive_seed(root_seed, MISSION_STREAM, cell, terrain, mission)


def mission_rng(seed: int) -> np.random.Generator:
    """The generator one mission is drawn from, given its :func:`mission_seed`."""
    return np.random.default_rng(int(seed))
