"""Planetary bodies a terrain can lie on, and their surface gravity (a recipe's ``[body]``).

A recipe names its body (``[body] name = "moon"``) or gives the gravity itself
(``[body] gravity_m_s2 = 1.62``); a trial uses it unless its study sets ``[sim] gravity_m_s2``
(offroadbench.sim.config.SimConfig.for_terrain). Values: mean surface gravity, NASA planetary fact
sheets (nssdc.gsfc.nasa.gov/planetary/factsheet): Moon 1.62, Mars 3.71 m/s^2; Earth 9.81, the
value the project has always used (standard gravity is 9.80665).

Soil parameters measured in 1 g are not validated in reduced gravity (offroadbench.sim.tyre_laws.terramechanics).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from offroadbench.config import check_range
from offroadbench.errors import InputError

__all__ = ["BODIES", "body_gravity", "terrain_gravity_and_soil"]

#: body name -> mean surface gravity, m/s^2
BODIES = {"earth": 9.81, "moon": 1.62, "mars": 3.71}


def body_gravity(table: Mapping[str, Any], where: str = "[body]") -> tuple[str, float]:
    """(body name, gravity m/s^2) of a ``[body]`` table: ``name`` (one of BODIES) or ``gravity_m_s2``
    (> 0; then the name is ``custom`` unless given too)."""
    if not isinstance(table, Mapping):
        raise InputError(f"{where}: expected a table with name or gravity_m_s2")
    unknown = sorted(set(table) - {"name", "gravity_m_s2"})
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(unknown)}; known keys: gravity_m_s2, name")
    name = table.get("name")
    g = table.get("gravity_m_s2")
    if g is not None:
        check_range(None, f"{where} gravity_m_s2", g, lo=0, lo_open=True)
        if name is not None and not isinstance(name, str):
            raise InputError(f"{where}: name must be a string, got {name!r}")
        return (name or "custom"), float(g)
    if not isinstance(name, str) or name not in BODIES:
        raise InputError(f"{where}: name = {name!r}; allowed: {', '.join(BODIES)} (or give gravity_m_s2)")
    return name, BODIES[name]


def terrain_gravity_and_soil(recipe_data: Any) -> tuple[float | None, str | None]:
    """(gravity m/s^2 or None, soil name or None) of a recipe's TOML dict (e.g. the one stored in a
    PNG's sidecar); None where it names no ``[body]`` or ``[soil]``."""
    if not isinstance(recipe_data, Mapping):
        return None, None
    body = recipe_data.get("body")
    gravity = body_gravity(body, "recipe [body]")[1] if body is not None else None
    soil = recipe_data.get("soil")
    name = soil.get("name") if isinstance(soil, Mapping) else None
    return gravity, name if isinstance(name, str) and name else None
