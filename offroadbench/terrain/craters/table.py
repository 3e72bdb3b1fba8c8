"""The crater list model: one row per crater, kept apart from any elevation model.

Parkes & Martin (Parkes & Martin 1999, Sec. 3) keep crater files separate from the DEM, so the same craters can be
put on different base terrains. :class:`CraterTable` is that list in memory; the CSV form is
read and written by :mod:`offroadbench.io.craters_csv`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from offroadbench.errors import InputError
from offroadbench.terrain.craters.profiles import PROFILES

__all__ = ["CraterTable"]


def _column(values, name: str, n: int | None) -> np.ndarray:
    arr = np.array(values, dtype=np.float64, copy=True).reshape(-1)
    if n is not None and arr.size != n:
        raise InputError(f"crater table: column {name} has {arr.size} values, expected {n}")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class CraterTable:
    """Craters as parallel arrays (metres). Immutable.

    Attributes:
        x_m, y_m: centre, metres in the Heightmap frame (x = column * cell, y = row * cell).
        diameter_m: rim-to-rim diameter (for Li kernels 1-2: apparent diameter), > 0.
        age: normalised age (>= 0; larger is older), NaN if unknown.
        degradation: 0 fresh .. 1 fully degraded, NaN if it is to be derived from ``age``.
        profile: name of a registered crater profile, one per crater.
    """

    x_m: np.ndarray
    y_m: np.ndarray
    diameter_m: np.ndarray
    age: np.ndarray
    degradation: np.ndarray
    profile: tuple[str, ...]

    def __post_init__(self) -> None:
        x = _column(self.x_m, "x_m", None)
        n = x.size
        cols = {"x_m": x}
        for name in ("y_m", "diameter_m", "age", "degradation"):
            cols[name] = _column(getattr(self, name), name, n)
        for name, arr in cols.items():
            object.__setattr__(self, name, arr)
        prof = (self.profile,) * n if isinstance(self.profile, str) else tuple(str(p) for p in self.profile)
        if len(prof) != n:
            raise InputError(f"crater table: column profile has {len(prof)} values, expected {n}")
        object.__setattr__(self, "profile", prof)
        self._validate()

    def _validate(self) -> None:
        def first_bad(mask: np.ndarray) -> int:
            return int(np.flatnonzero(mask)[0])

        for name in ("x_m", "y_m"):
            bad = ~np.isfinite(getattr(self, name))
            if bad.any():
                raise InputError(f"crater table: {name} of crater {first_bad(bad)} is not finite")
        d = self.diameter_m
        bad = ~(np.isfinite(d) & (d > 0))
        if bad.any():
            i = first_bad(bad)
            raise InputError(f"crater table: diameter_m of crater {i} is {d[i]!r}; must be > 0")
        s = self.degradation
        bad = ~np.isnan(s) & ~((s >= 0) & (s <= 1))
        if bad.any():
            i = first_bad(bad)
            raise InputError(f"crater table: degradation of crater {i} is {s[i]!r}; allowed: [0, 1] or empty")
        a = self.age
        bad = ~np.isnan(a) & ~(np.isfinite(a) & (a >= 0))
        if bad.any():
            i = first_bad(bad)
            raise InputError(f"crater table: age of crater {i} is {a[i]!r}; allowed: >= 0 or empty")
        for i, p in enumerate(self.profile):
            if p not in PROFILES:
                raise InputError(f"crater table: profile of crater {i} is {p!r}; known: {', '.join(sorted(PROFILES))}")

    def __len__(self) -> int:
        return int(self.x_m.size)

    def take(self, index) -> "CraterTable":
        """The craters at ``index`` (an index array or boolean mask), in that order."""
        idx = np.arange(len(self))[index]
        return CraterTable(
            x_m=self.x_m[idx],
            y_m=self.y_m[idx],
            diameter_m=self.diameter_m[idx],
            age=self.age[idx],
            degradation=self.degradation[idx],
            profile=tuple(self.profile[i] for i in idx),
        )

    def oldest_first(self) -> "CraterTable":
        """Sorted by age, oldest first (Martin et al. 2014, Sec. III.C); craters of unknown age keep their order, last."""
        key = np.where(np.isnan(self.age), -np.inf, self.age)
        return self.take(np.argsort(-key, kind="stable"))

    def with_degradation(self, degradation) -> "CraterTable":
        """A copy with another degradation column."""
        return CraterTable(
            x_m=self.x_m, y_m=self.y_m, diameter_m=self.diameter_m, age=self.age,
            degradation=degradation, profile=self.profile,
        )

    @classmethod
    def empty(cls) -> "CraterTable":
        return cls(x_m=[], y_m=[], diameter_m=[], age=[], degradation=[], profile=())

    def __repr__(self) -> str:
        if not len(self):
            return "CraterTable(0 craters)"
        return (
            f"CraterTable({len(self)} craters, D=[{self.diameter_m.min():.3g}, {self.diameter_m.max():.3g}] m, "
            f"profiles={sorted(set(self.profile))})"
        )
