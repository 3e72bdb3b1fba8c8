"""Random straight-line A-to-B missions on a classified terrain (Majhor & Bos 2023, Sec. 2.3, Fig. 4c).

A start is drawn uniformly from the cells of the *closed* class map whose class is in
``start_classes`` (paper: low) and that lie at least ``border_m`` from the map edge (paper: 5 m).
A heading is drawn uniformly in [0, 360) deg and the candidate goal lies ``length_m`` away along
it (paper: 35 m); it is accepted if it is inside the border and its nearest cell's class is in
``goal_classes`` (paper: low or semi). Otherwise a new start and heading are drawn, up to
``max_tries`` candidates per mission; then the request is called impossible.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from offroadbench.analysis.roughness import CLASS_NAMES, border_mask
from offroadbench.config import check_choice, check_int, check_range
from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap

__all__ = ["MissionConfig", "Mission", "MissionSites", "NoMissionError", "map_too_small", "mission_sites",
           "sample_missions", "sample_mission"]

#: candidates drawn per vectorised batch while sampling
_BATCH = 256



class NoMissionError(InputError):
    """This terrain admits no mission under the rules (no start cell, or no goal found within the
    tries): a property of the drawn terrain, not of the settings. ``drive`` reports it as bad input
    (one line); a study stores the terrain's trials as faults (offroadbench.study.execution.tasks.run_terrain)."""

@dataclass(frozen=True, kw_only=True)
class MissionConfig:
    """How many missions to draw and where they may start and end."""

    count: int = 20
    """Missions per terrain (paper: 20)."""
    length_m: float = 35.0
    """Straight-line start-goal distance, metres (paper: 35 m)."""
    border_m: float = 5.0
    """No start or goal closer than this to the map edge, metres (paper: 5 m)."""
    start_classes: tuple[str, ...] = ("low",)
    """Roughness classes (of the closed map) a start may lie on (paper: low)."""
    goal_classes: tuple[str, ...] = ("low", "semi")
    """Roughness classes a goal may lie on (paper: low or semi)."""
    max_tries: int = 20000
    """Candidate (start, heading) draws per mission before the request is called impossible."""

    def __post_init__(self) -> None:
        check_int(self, "count", self.count, lo=1)
        check_range(self, "length_m", self.length_m, lo=0, lo_open=True)
        check_range(self, "border_m", self.border_m, lo=0)
        check_int(self, "max_tries", self.max_tries, lo=1)
        for field in ("start_classes", "goal_classes"):
            names = tuple(getattr(self, field))
            object.__setattr__(self, field, names)
            if not names:
                raise InputError(f"MissionConfig.{field} must name at least one class of {', '.join(CLASS_NAMES)}")
            for name in names:
                check_choice(self, field, name, CLASS_NAMES)


@dataclass(frozen=True)
class Mission:
    """One straight-line mission: start and goal in map metres, heading = direction start -> goal."""

    index: int
    start_xy_m: tuple[float, float]
    goal_xy_m: tuple[float, float]
    heading_rad: float
    """Counter-clockwise from +x, in [0, 2 pi)."""

    @property
    def length_m(self) -> float:
        return math.hypot(self.goal_xy_m[0] - self.start_xy_m[0], self.goal_xy_m[1] - self.start_xy_m[1])

    @classmethod
    def between(cls, index: int, start_xy_m, goal_xy_m) -> "Mission":
        """A mission from explicit end points (tests, hand-made missions)."""
        sx, sy = map(float, start_xy_m)
        gx, gy = map(float, goal_xy_m)
        return cls(index, (sx, sy), (gx, gy), math.atan2(gy - sy, gx - sx) % (2 * math.pi))


def _class_mask(classes: np.ndarray, names: tuple[str, ...]) -> np.ndarray:
    """Where ``classes`` holds one of the classes ``names`` (a comparison per class: the same mask as
    ``np.isin``, a third of its time on a 1009^2 map)."""
    mask = np.zeros(classes.shape, dtype=bool)
    for n in names:
        mask |= classes == CLASS_NAMES.index(n)
    return mask


def map_too_small(width_m: float, height_m: float, cfg: MissionConfig) -> str | None:
    """Why a map of ``width_m`` x ``height_m`` (first to last sample, metres) cannot hold missions of
    ``cfg.length_m`` inside its ``cfg.border_m`` (the diagonal of what the border leaves is shorter),
    in one line; None when it can. A setting, not a property of a drawn terrain: a study refuses it
    as bad input (a failure search stores such a proposal as holding no mission)."""
    usable_w = width_m - 2 * cfg.border_m
    usable_h = height_m - 2 * cfg.border_m
    if usable_w < 0 or usable_h < 0 or math.hypot(usable_w, usable_h) < cfg.length_m:
        return (f"map {width_m:g} x {height_m:g} m with a {cfg.border_m:g} m border leaves "
                f"{max(usable_w, 0):g} x {max(usable_h, 0):g} m: too small for {cfg.length_m:g} m missions")
    return None


@dataclass(frozen=True, eq=False)
class MissionSites:
    """Where a terrain's missions may start and end under one MissionConfig: computed once per
    terrain (:func:`mission_sites`) and shared by every mission drawn on it."""

    starts: np.ndarray
    """Flat indices of the start cells (a ``start_classes`` cell inside the border), ascending."""
    goal_ok: np.ndarray
    """Bool map: a ``goal_classes`` cell inside the border."""


def mission_sites(hm: Heightmap, closed_classes: np.ndarray, cfg: MissionConfig) -> MissionSites:
    """The start cells and goal map of missions under ``cfg`` (see :func:`sample_missions`, which
    raises what this raises: InputError for a map too small or a class map of another shape,
    NoMissionError when no start cell exists)."""
    classes = np.asarray(closed_classes)
    if classes.shape != hm.shape:
        raise InputError(f"class map shape {classes.shape} does not match the heightmap's {hm.shape}")
    too_small = map_too_small(hm.width_m, hm.height_m, cfg)
    if too_small:
        raise InputError(too_small)
    inside = border_mask(hm.shape, cfg.border_m, hm.cell_size_m)
    starts = np.flatnonzero(_class_mask(classes, cfg.start_classes) & inside)
    if starts.size == 0:
        raise NoMissionError(
            f"no start cell: no {'/'.join(cfg.start_classes)} cell lies at least {cfg.border_m:g} m from the map edge "
            "in the class map after its morphological closing"
        )
    return MissionSites(starts=starts, goal_ok=_class_mask(classes, cfg.goal_classes) & inside)


def sample_missions(
    hm: Heightmap, closed_classes: np.ndarray, cfg: MissionConfig, rng: np.random.Generator,
    sites: MissionSites | None = None,
) -> list[Mission]:
    """Draw ``cfg.count`` missions (paper Sec. 2.3); a pure function of its inputs.

    ``closed_classes`` is the class map after morphological closing (uint8 LOW/SEMI/HIGH, the
    heightmap's shape). Raises InputError for an impossible request: a map whose usable square is
    shorter (along its diagonal) than the mission, no start cell, or no valid goal within
    ``cfg.max_tries`` draws. ``sites``: :func:`mission_sites` of the same terrain and ``cfg``, when
    the caller draws several times on one terrain (None: computed here).
    """
    if sites is None:
        sites = mission_sites(hm, closed_classes, cfg)
    starts, goal_ok, cell = sites.starts, sites.goal_ok, hm.cell_size_m

    missions: list[Mission] = []
    for index in range(cfg.count):
        tries = 0
        found = None
        while found is None and tries < cfg.max_tries:
            n = min(_BATCH, cfg.max_tries - tries)
            tries += n
            pick = starts[rng.integers(0, starts.size, size=n)]
            heading = rng.uniform(0.0, 2.0 * math.pi, size=n)
            sr, sc = np.divmod(pick, hm.cols)
            gx = sc * cell + cfg.length_m * np.cos(heading)
            gy = sr * cell + cfg.length_m * np.sin(heading)
            gc = np.rint(gx / cell).astype(int)
            gr = np.rint(gy / cell).astype(int)
            on_map = (gc >= 0) & (gc < hm.cols) & (gr >= 0) & (gr < hm.rows)
            ok = on_map.copy()
            ok[on_map] = goal_ok[gr[on_map], gc[on_map]]
            hits = np.flatnonzero(ok)
            if hits.size:
                j = hits[0]
                found = Mission(
                    index,
                    (float(sc[j] * cell), float(sr[j] * cell)),
                    (float(gx[j]), float(gy[j])),
                    float(heading[j]),
                )
        if found is None:
            raise NoMissionError(
                f"could not place mission {index} after {cfg.max_tries} tries: no {'/'.join(cfg.goal_classes)} "
                f"goal {cfg.length_m:g} m from a {'/'.join(cfg.start_classes)} start inside the {cfg.border_m:g} m border"
            )
        missions.append(found)
    return missions


def sample_mission(hm: Heightmap, closed_classes: np.ndarray, cfg: MissionConfig, index: int, seed: int,
                   sites: MissionSites | None = None) -> Mission:
    """Mission ``index`` drawn alone from its own seed (:func:`offroadbench.seeding.mission_seed`),
    so it does not depend on which other missions are drawn, pending or done. ``sites`` as in
    :func:`sample_missions`."""
    import dataclasses

    from offroadbench.seeding import mission_rng

    (mission,) = sample_missions(hm, closed_classes, dataclasses.replace(cfg, count=1), mission_rng(seed), sites)
    return dataclasses.replace(mission, index=index)

