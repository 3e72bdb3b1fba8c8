"""A study's planned tests on each physics engine: the cross-engine verdict of every test of the
``[analysis]`` plan in a study with a ``sim.engine`` grid axis, and the engine difference of its
per-terrain effect with a terrain-bootstrap interval (Efron & Tibshirani 1993)."""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np
import pandas as pd

from offroadbench.study.stats.plan import (AnalysisPlan, Comparison, cell_label, expand, terrain_differences,
                                           terrain_metric)

__all__ = ["ENGINE_KEY", "engine_table", "engine_verdict"]

#: the grid key of the physics engine
ENGINE_KEY = "sim.engine"


def engine_table(plan: AnalysisPlan, meta: Mapping[str, Any], trials: pd.DataFrame, terrains: pd.DataFrame | None,
                 confirm: pd.DataFrame) -> pd.DataFrame | None:
    """Each planned test on each engine of a study with a ``sim.engine`` grid axis (the same terrains and
    missions on both: terrain j of every cell has one seed), with the cross-engine verdict and the engine
    difference; None without such an axis (or with one engine).

    ``confirm`` is :func:`confirmatory_table` of the same plan (one Holm family over every engine's tests).
    One row per (comparison, stratum without the engine, engine): effect, ci_low, ci_high, p_adjusted,
    reject; ``verdict`` (the same in the test's rows): ``holds on both`` (rejected on every engine, in one
    direction), ``holds on <engine> only``, ``holds on neither``, or ``opposite directions``;
    ``engine_difference`` (per terrain, the effect's difference on the second engine minus the first,
    averaged over the terrains both have; ``engines`` names the order) with its terrain-bootstrap interval
    (Efron & Tibshirani 1993; a generator of the test's own). Comparisons of the engine itself are left out
    (they are the engine difference)."""
    from offroadbench.study.stats.clustered import cluster_bootstrap, keyed_rng

    columns = meta.get("columns", {})
    axes = {a["key"]: list(a["values"]) for a in meta["study"]["grid"]}
    engines = axes.get(ENGINE_KEY, [])
    if len(engines) < 2:
        return None
    cells = [c["values"] for c in sorted(meta["cells"], key=lambda c: c["index"])]
    groups: dict[tuple[str, str], list[tuple[Any, int, list[int], list[int], Comparison]]] = {}
    for i, (comp, stratum, ti, ci) in enumerate(expand(plan, cells)):
        if ENGINE_KEY not in stratum:
            continue
        rest = {k: v for k, v in stratum.items() if k != ENGINE_KEY}
        pooled = f"; pooled over {', '.join(columns.get(k, k) for k in comp.pool)}" if comp.pool else ""
        groups.setdefault((comp.name, cell_label(rest, columns) + pooled), []).append((stratum[ENGINE_KEY], i, ti, ci, comp))
    rows = []
    for (name, label), members in groups.items():
        members.sort(key=lambda m: engines.index(m[0]))
        comp = members[0][4]
        vals = terrain_metric(trials, terrains, comp.metric, comp.summary)
        per = {}
        for eng, _, ti, ci, _ in members:
            both, d = terrain_differences(vals, ti, ci)
            per[eng] = pd.Series(d, index=both.index)
        first, last = members[0][0], members[-1][0]
        common = per[first].index.intersection(per[last].index)
        dd = (per[last].reindex(common) - per[first].reindex(common)).to_numpy(float)
        boot = cluster_bootstrap(dd, np.mean, keyed_rng(plan.seed, "engine difference", name, label), plan.n_boot,
                                 level=plan.confidence)
        rej = {eng: bool(confirm.iloc[i]["reject"]) for eng, i, *_ in members}
        sign = {eng: np.sign(confirm.iloc[i]["effect"]) for eng, i, *_ in members}
        verdict = engine_verdict(rej, sign)
        for eng, i, *_ in members:
            r = confirm.iloc[i]
            rows.append({"comparison": name, "stratum": label, "metric": comp.metric, "engine": eng,
                         "terrains": r["terrains"], "effect": r["effect"], "ci_low": r["ci_low"], "ci_high": r["ci_high"],
                         "p_adjusted": r["p_adjusted"], "reject": r["reject"], "verdict": verdict,
                         "engines": f"{last} - {first}", "engine_difference": boot.estimate,
                         "engine_difference_low": boot.low, "engine_difference_high": boot.high,
                         "engine_difference_terrains": int(dd.size)})
    return pd.DataFrame(rows) if rows else None


def engine_verdict(rejected: Mapping[str, bool], sign: Mapping[str, float]) -> str:
    """A planned test's verdict over engines from its rejection and effect sign on each: ``holds on both``
    (rejected on every engine, in one direction; ``holds on every engine`` with more than two),
    ``opposite directions``, ``holds on <engine> only`` or ``holds on neither``."""
    held = [e for e in rejected if rejected[e]]
    if len(held) == len(rejected) and len({sign[e] for e in held}) == 1:
        return "holds on both" if len(rejected) == 2 else "holds on every engine"
    if len(held) > 1 and len({sign[e] for e in held}) > 1:
        return "opposite directions"
    if held:
        return f"holds on {' and '.join(held)} only"
    return "holds on neither"
