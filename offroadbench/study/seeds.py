"""Seeds of a study: one child seed per terrain and one per mission, from ``np.random.SeedSequence``.

Every seed is a pure function of (root seed, stream, cell key, terrain index[, mission index]),
built as ``SeedSequence(root_seed, spawn_key=(stream, cell_key, terrain[, mission]))``; this is
the same child ``SeedSequence.spawn`` would hand out along that path. So trial k of terrain j
gets the same seed whatever the order of execution, the number of workers or a resumption, and
adding missions, terrains or grid values does not change the seeds of the existing ones.

Seeds are stored and passed on as plain 63-bit integers (``generate_state`` of the child), so
a stored ``terrain_seed`` reproduces the terrain with ``generate_terrain(recipe, terrain_seed)``
(or ``offroadbench terrain generate --seed``) and a ``mission_seed`` the mission with
``np.random.default_rng(mission_seed)``.

Cell keys. With paired terrains (the default) every grid cell uses cell key 0: terrain j of
each cell comes from the same seed, so the cells differ only by their grid values (common
random numbers; for the paper study, the 20 terrains of D = 2.3 and of D = 2.6 share their
low- and mid-frequency layers and their phases). Unpaired, the cell key is a stable hash of
the cell's grid values, so each cell has its own terrains.
"""

from __future__ import annotations

import hashlib
import json
from typing import Any, Mapping

import numpy as np

__all__ = ["TERRAIN_STREAM", "MISSION_STREAM", "derive_seed", "cell_key", "terrain_seed", "mission_seed"]

#: First spawn-key entry of the two seed streams.
TERRAIN_STREAM = 0
MISSION_STREAM = 1


def derive_seed(root_seed: int, *path: int) -> int:
    """The 63-bit integer seed of the child ``SeedSequence(root_seed, spawn_key=path)``."""
    child = np.random.SeedSequence(int(root_seed), spawn_key=tuple(int(p) for p in path))
    return int(child.generate_state(1, np.uint64)[0] >> np.uint64(1))


def cell_key(values: Mapping[str, Any], paired: bool) -> int:
    """Spawn-key entry of a grid cell: 0 when paired, else a stable 31-bit hash of its values."""
    if paired:
        return 0
    text = json.dumps(dict(values), sort_keys=True, default=repr)
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:4], "big") >> 1


def terrain_seed(root_seed: int, cell: int, terrain: int) -> int:
    """Seed of terrain ``terrain`` of the cell with key ``cell``."""
    return derive_seed(root_seed, TERRAIN_STREAM, cell, terrain)


def mission_seed(root_seed: int, cell: int, terrain: int, mission: int) -> int:
    """Seed of mission ``mission`` on terrain ``terrain`` of the cell with key ``cell``."""
    return derive_seed(root_seed, MISSION_STREAM, cell, terrain, mission)
