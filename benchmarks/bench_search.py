"""Failure search: trials the falsifier and nominal (random) sampling spend to find their first k
distinct failures, over several seeds, on the same domain.

    .venv/bin/python benchmarks/bench_search.py [--seeds 0 1 2] [--k 10] [--falsify-budget 64] \
        [--random-budget 320] [--workers 1] [--planner straight|astar] [--keep DIR] [--smoke]
    .venv/bin/python benchmarks/bench_search.py --mc-run RUN_DIR [--seeds 0 1] [--planner astar] \
        [--permutations 2000] [--with-run]

The domain is experiments/failure-search.toml's, the falsifier its settings (TPE and the local
search), with the one ``--planner`` (default the straight line; ``astar``: A*). Each seed is the
study's root seed: it changes the optimiser's and the sampler's streams and the terrains and
missions. A stream that has not found k distinct failures within its budget counts as "> budget".
Distinct: the study file's rule, at least ``distinct_distance`` (0.1) of a range apart in some
parameter (offroadbench.search.estimators.distinct_failures); the rows also say on how many
different terrains the first k distinct failures lie.

Default mode: a falsifier stream and a random stream per seed; prints one row per seed, the medians
with their range, and P(failure) by plain Monte Carlo from the random streams (all seeds pooled).

``--mc-run RUN_DIR`` (the ratio mode): the random baseline is the stored ``random`` stream of a
finished search of the same domain (the committed study's Monte Carlo reference, the group of
``--planner``): nominal draws are independent, so ``--permutations`` random orders of that pool are
draws of what a random stream needs to its k-th distinct failure (without replacement from a finite
pool: a pool several times the trials needed keeps this close; with few failures in the pool it
pushes the k-th toward the pool's end). Two model baselines beside it: the negative binomial at the
pool's P(failure) (trials to the k-th failure, distinctness ignored: a bound in random sampling's
favour) and simulated random streams (nominal parameter draws failing with that probability
independently of the parameters, distinctness counted). The falsifier runs for every
``--seeds`` (``--with-run`` adds the run's own falsifier stream of that planner as one more seed).
Prints the falsifier's median and range over seeds, the random baseline's median and 10-90 % range
over orders, and their ratio.

``--smoke``: one seed, budgets 8, k = 1 (checks that the benchmark runs).
"""

from __future__ import annotations

import argparse
import copy
import tempfile
import time
from pathlib import Path

import numpy as np

from offroadbench.config import load_toml
from offroadbench.search import run_search, search_from_data
from offroadbench.search.estimators import distinct_failures, mc_estimate
from offroadbench.search.report import first_failures, search_table

ROOT = Path(__file__).resolve().parents[1]


def domain(seed: int, method: str, budget: int, planner: str = "straight") -> dict:
    data = copy.deepcopy(load_toml(ROOT / "experiments" / "failure-search.toml"))
    data.pop("grid", None)
    data["study"].update(name=f"bench-search-{method}-{seed}", root_seed=seed)
    data["search"].update(methods=[method], budget=budget)
    data["search"].pop("mc_budget", None)
    data["planner"] = {"name": planner}
    return data


def _first_k_terrains(cfg, stream, k: int) -> int:
    """Different terrains among a stream's first k distinct failures."""
    s = stream[stream["done"]]
    counts = distinct_failures(cfg.unit(s[list(cfg.keys)].to_numpy(dtype=float)), s["failed"].to_numpy(),
                               cfg.distinct_distance)
    new = np.nonzero(np.diff(np.concatenate([[0], counts])) > 0)[0][:k]
    return int(s["terrain_seed"].iloc[new].nunique())


def _spread(v: np.ndarray) -> str:
    return f"median {np.median(v):g}, range {v.min():g}-{v.max():g}"


def ratio_mode(args, base: Path) -> None:
    """The falsifier over seeds against random orders of a stored Monte Carlo pool (module docstring)."""
    pool_df, pool_plan = search_table(args.mc_run)
    groups = [i for i, g in enumerate(pool_plan.groups) if g.values.get("planner.name", args.planner) == args.planner]
    if not groups:
        raise SystemExit(f"{args.mc_run}: no group with planner.name = {args.planner}")
    grp = groups[0]
    cfg = pool_plan.search
    pool = pool_df[(pool_df["group"] == grp) & (pool_df["method"] == "random") & pool_df["done"]].reset_index(drop=True)
    rng = np.random.default_rng(args.seeds[0])
    rand = []
    for _ in range(args.permutations):
        n = first_failures(cfg, pool.iloc[rng.permutation(len(pool))].reset_index(drop=True), args.k)
        rand.append(n if np.isfinite(n) else np.inf)
    rand = np.array(rand)
    est = mc_estimate(pool["failed"].to_numpy())
    # trials to the k-th failure of independent nominal draws: k + NegBin(k, p) (distinctness only delays it)
    nb = {name: k_trials(args.k, q) for name, q in (("p", est.p), ("low", est.low), ("high", est.high))}
    print(f"random, negative binomial at the pool's P(failure): trials to the {args.k}-th failure, median "
          f"{nb['p']:g} ({nb['high']:g}-{nb['low']:g} at the interval's ends)", flush=True)
    model = {name: model_trials(cfg, args.k, q, args.permutations, rng) for name, q in
             (("p", est.p), ("low", est.low), ("high", est.high))}
    print(f"random, simulated nominal draws failing with the pool's P(failure) independently of the parameters: "
          f"trials to {args.k} distinct failures, median {model['p']:g} ({model['high']:g}-{model['low']:g} at the "
          "interval's ends)", flush=True)
    print(f"random ({args.planner}, {len(pool)} stored nominal trials, {est.failures} failures, P = {est.p:.4f}, "
          f"95 % CI {est.low:.4f}-{est.high:.4f}): trials to {args.k} distinct failures over {args.permutations} orders: "
          f"median {np.median(rand):g}, 10-90 % {np.quantile(rand, 0.1):g}-{np.quantile(rand, 0.9):g}, "
          f"{np.mean(~np.isfinite(rand)):.0%} of orders never reach it", flush=True)
    fals = []
    runs = [(f"run {args.mc_run}", pool_df[(pool_df["group"] == grp) & (pool_df["method"] == "falsify")])] \
        if args.with_run else []
    for seed in args.seeds:
        plan = search_from_data(domain(seed, "falsify", args.falsify_budget, args.planner), where=f"bench seed {seed}")
        out = base / f"falsify-{args.planner}-{seed}"
        run_search(plan, out, executor="local", workers=args.workers)
        runs.append((f"seed {seed}", search_table(out)[0]))
    for name, df in runs:
        n = first_failures(cfg, df, args.k)
        fals.append(n if np.isfinite(n) else np.inf)
        done = df[df["done"]]
        print(f"falsify {name}: {int(done['failed'].sum())} failures in {len(done)} trials, k-th distinct at "
              f"{'> ' + str(len(done)) if not np.isfinite(n) else int(n)}, on {_first_k_terrains(cfg, df, args.k)} "
              "terrain(s)", flush=True)
    fals = np.array(fals)
    print(f"falsify ({args.planner}): trials to {args.k} distinct failures over {len(fals)} seeds: {_spread(fals)}")
    f_med = np.median(fals)
    print(f"ratio, random orders of the pool / falsify median: {np.median(rand) / f_med:.1f}x (over the falsifier's "
          f"range: {np.median(rand) / fals.max():.1f}x-{np.median(rand) / fals.min():.1f}x)")
    for name, r in (("negative binomial", nb), ("simulated nominal draws", model)):
        print(f"ratio, {name} / falsify median: {r['p'] / f_med:.1f}x (over the falsifier's range: "
              f"{r['p'] / fals.max():.1f}x-{r['p'] / fals.min():.1f}x; at the P interval's ends: "
              f"{r['high'] / f_med:.1f}x-{r['low'] / f_med:.1f}x)")


def model_trials(cfg, k: int, p: float, runs: int, rng: np.random.Generator) -> float:
    """Median trials to k distinct failures of simulated random streams: nominal parameter draws
    (the search's nominal, through its standard-normal map), each failing with probability p
    independently of its parameters (the study's rule of distinctness applied)."""
    if not 0 < p < 1:
        return float("inf")
    n = int(50 * k / p)
    out = []
    for _ in range(runs):
        failed = rng.random(n) < p
        x = cfg.from_z(rng.standard_normal((int(failed.sum()), cfg.dim)))
        counts = distinct_failures(cfg.unit(x), np.ones(len(x), bool), cfg.distinct_distance)
        hit = np.nonzero(counts >= k)[0]
        out.append(np.nonzero(failed)[0][hit[0]] + 1 if len(hit) else np.inf)
    return float(np.median(out))


def k_trials(k: int, p: float) -> float:
    """Median trials to the k-th failure of independent draws failing with probability p."""
    from scipy import stats

    return float(k + stats.nbinom(k, p).median()) if 0 < p < 1 else float("inf")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--k", type=int, default=10)
    ap.add_argument("--falsify-budget", type=int, default=64)
    ap.add_argument("--random-budget", type=int, default=320)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--planner", default="straight", help="straight (default) or astar")
    ap.add_argument("--keep", help="keep the run directories here (default: a temporary folder)")
    ap.add_argument("--mc-run", help="ratio mode: a finished search's run directory whose random stream is the baseline")
    ap.add_argument("--permutations", type=int, default=2000, help="ratio mode: random orders of the stored pool")
    ap.add_argument("--with-run", action="store_true", help="ratio mode: count the run's own falsifier stream as a seed")
    ap.add_argument("--smoke", action="store_true")
    args = ap.parse_args()
    if args.smoke:
        args.seeds, args.k, args.falsify_budget, args.random_budget = args.seeds[:1], 1, 8, 8
    base = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="bench-search-"))
    if args.mc_run:
        ratio_mode(args, base)
        return
    found = {"falsify": [], "random": []}
    nominal_failed = []
    for seed in args.seeds:
        row = []
        for method, budget in (("falsify", args.falsify_budget), ("random", args.random_budget)):
            plan = search_from_data(domain(seed, method, budget, args.planner), where=f"bench seed {seed}")
            out = base / f"{method}-{seed}"
            t0 = time.perf_counter()
            run_search(plan, out, executor="local", workers=args.workers)
            df, _ = search_table(out)
            n = first_failures(plan.search, df, args.k)
            found[method].append(n if np.isfinite(n) else np.inf)
            if method == "random":
                nominal_failed.extend(df["failed"].tolist())
            row.append(f"{method}: {int(df['failed'].sum())} failures in {len(df)} trials, k-th distinct at "
                       f"{'> ' + str(budget) if not np.isfinite(n) else int(n)} on "
                       f"{_first_k_terrains(plan.search, df, args.k)} terrain(s) ({time.perf_counter() - t0:.0f} s)")
        print(f"seed {seed}: " + "; ".join(row), flush=True)
    for method, values in found.items():
        v = np.array(values, dtype=float)
        print(f"{method}: trials to {args.k} distinct failures, median {np.median(v):g} (range {v.min():g}-{v.max():g})")
    est = mc_estimate(nominal_failed)
    print(f"P(failure), nominal sampling pooled: {est.p:.4f} ({est.failures}/{est.n}; 95 % CI {est.low:.4f}-{est.high:.4f})")
    print(f"run directories: {base}")


if __name__ == "__main__":
    main()
