"""Failure search: trials the falsifier and nominal (random) sampling spend to find their first k
distinct failures, and the spread of the importance-sampling estimate, over repeats of one domain.

    .venv/bin/python benchmarks/bench_search.py [--study FILE] [--seeds 0 1 2 | --replicates 1 2 3] [--k 10] \
        [--falsify-budget 64] [--random-budget 320] [--workers 1] [--planner straight|astar] [--keep DIR] [--smoke]
    .venv/bin/python benchmarks/bench_search.py --mc-run RUN_DIR [--study FILE] [--seeds 0 1 | --replicates 1 2] \
        [--planner astar] [--permutations 2000] [--with-run] [--method falsify|ce-is]

The domain is ``--study``'s (default experiments/failure-search.toml), its [search] settings, with the
one ``--planner`` (default the straight line; ``astar``: A*). A repeat is either a root seed
(``--seeds``: the study's root seed replaced, so the optimiser's and the sampler's streams and the
terrains and missions change, and a fixed site with them) or a replicate (``--replicates``:
``[search] replicate``, the same root seed: other streams and nuisance draws on the same domain, a
fixed site kept). A stream that has not found k distinct failures within its budget counts as
"> budget". Distinct: the study file's rule, at least ``distinct_distance`` of a range apart in
some parameter (offroadbench.search.estimators.distinct_failures); the rows also say on how many
different terrains the first k distinct failures lie.

Default mode: a falsifier stream and a random stream per repeat; prints one row per repeat, the
medians with their range, and P(failure) by plain Monte Carlo from the random streams (pooled).

``--mc-run RUN_DIR`` (the ratio modes): the baseline is the stored ``random`` stream of a finished
search of the same domain (the committed study's Monte Carlo reference, the group of ``--planner``).

- ``--method falsify`` (default): nominal draws are independent, so ``--permutations`` random
  orders of that pool are draws of what a random stream needs to its k-th distinct failure (without
  replacement from a finite pool: with few failures in the pool it pushes the k-th toward the
  pool's end). Two model baselines beside it: the negative binomial at the pool's P(failure)
  (trials to the k-th failure, distinctness ignored: a bound in random sampling's favour) and
  bootstrap streams (draws with replacement from the pool, parameters and outcome together, so
  the failures keep their parameters; distinctness counted). The falsifier runs for every repeat
  (``--with-run`` adds the run's own falsifier stream as one more). Prints the falsifier's median
  and range over repeats, each baseline's median, and their ratios.
- ``--method ce-is``: a cross-entropy importance-sampling stream (the study's ``ce_*`` settings and
  ``ce_budget``) per repeat (``--with-run`` adds the run's own): its estimate, relative error and
  interval, plain Monte Carlo's trials for that relative error at the pool's P over the trials it
  spent (offroadbench.search.report.mc_trials_ratio), and whether its interval holds the pool's
  P; then the median and range of the ratio over repeats and how many intervals cover.

``--collect RUN_DIR ... --repeats-csv FILE``: append the streams of finished repeat run directories
(each one method, one planner, one ``[search] replicate``, as the modes above keep them with
``--keep``) to a results folder's repeats table (planner, replicate, method, then the search
table's columns); a stream already in the table is refused.

``--results FOLDER --study FILE``: the committed figures of a results folder (its trials.csv,
repeats.csv and search.toml; the analysis plan of ``--study``) for every planner
(offroadbench.search.evaluate.results_figures), printed and written to FOLDER as
is_repeats.csv, falsifier_baselines.csv, falsifier_streams.csv, uniform_streams.csv,
sensitivity.csv and modes.csv (those it has: a folder without falsifier streams has no falsifier
tables), and reference.csv where the plan's reference is another folder's boundary
(``[analysis] reference_from``: the reference, its bracket and bootstrap interval, and this
folder's trials checked against that boundary).

``--smoke``: one repeat, budgets 8, k = 1 (checks that the benchmark runs).
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
from offroadbench.search.report import estimates, first_failures, mc_trials_ratio, search_table

ROOT = Path(__file__).resolve().parents[1]


DEFAULT_STUDY = ROOT / "experiments" / "failure-search.toml"


def domain(repeat: tuple[str, int], method: str, budget: int | None, planner: str = "straight",
           study: Path = DEFAULT_STUDY) -> dict:
    """The study's search with one method and one planner; ``repeat`` = ("seed", root seed) or
    ("replicate", r); ``budget`` None keeps the study's own (``ce_budget`` for ``ce-is``)."""
    data = copy.deepcopy(load_toml(study))
    data.pop("grid", None)
    kind, value = repeat
    data["study"].update(name=f"bench-search-{method}-{kind}{value}")
    if kind == "seed":
        data["study"]["root_seed"] = value
    else:
        data["search"]["replicate"] = value
    data["search"].update(methods=[method])
    if budget is not None:
        data["search"].update(budget=budget, ce_budget=budget)
    data["search"].pop("mc_budget", None)
    data["planner"] = {**data.get("planner", {}), "name": planner}
    return data


def _repeats(args) -> list[tuple[str, int]]:
    return [("replicate", r) for r in args.replicates] if args.replicates else [("seed", s) for s in args.seeds]


def _first_k_terrains(cfg, stream, k: int) -> int:
    """Different terrains among a stream's first k distinct failures."""
    s = stream[stream["done"]]
    counts = distinct_failures(cfg.unit(s[list(cfg.keys)].to_numpy(dtype=float)), s["failed"].to_numpy(),
                               cfg.distinct_distance)
    new = np.nonzero(np.diff(np.concatenate([[0], counts])) > 0)[0][:k]
    return int(s["terrain_seed"].iloc[new].nunique())


def _spread(v: np.ndarray) -> str:
    return f"median {np.median(v):g}, range {v.min():g}-{v.max():g}"


def _pool(args):
    """(pool plan, the --planner group's index, its stored finished random stream, MC estimate)."""
    pool_df, pool_plan = search_table(args.mc_run)
    groups = [i for i, g in enumerate(pool_plan.groups) if g.values.get("planner.name", args.planner) == args.planner]
    if not groups:
        raise SystemExit(f"{args.mc_run}: no group with planner.name = {args.planner}")
    grp = groups[0]
    pool = pool_df[(pool_df["group"] == grp) & (pool_df["method"] == "random") & pool_df["done"]].reset_index(drop=True)
    return pool_df, pool_plan, grp, pool, mc_estimate(pool["failed"].to_numpy())


def ratio_mode(args, base: Path) -> None:
    """The falsifier over repeats against random orders of a stored Monte Carlo pool (module docstring)."""
    pool_df, pool_plan, grp, pool, est = _pool(args)
    cfg = pool_plan.search
    rng = np.random.default_rng(0)
    rand = []
    for _ in range(args.permutations):
        n = first_failures(cfg, pool.iloc[rng.permutation(len(pool))].reset_index(drop=True), args.k)
        rand.append(n if np.isfinite(n) else np.inf)
    rand = np.array(rand)
    # trials to the k-th failure of independent nominal draws: k + NegBin(k, p) (distinctness only delays it)
    nb = {name: k_trials(args.k, q) for name, q in (("p", est.p), ("low", est.low), ("high", est.high))}
    print(f"random, negative binomial at the pool's P(failure): trials to the {args.k}-th failure, median "
          f"{nb['p']:g} ({nb['high']:g}-{nb['low']:g} at the interval's ends)", flush=True)
    boot = bootstrap_trials(cfg, pool, args.k, args.permutations, rng)
    print(f"random, bootstrap streams (draws with replacement from the pool, parameters and outcome together): "
          f"trials to {args.k} distinct failures, median {np.median(boot):g}, 10-90 % "
          f"{np.quantile(boot, 0.1):g}-{np.quantile(boot, 0.9):g}", flush=True)
    print(f"random ({args.planner}, {len(pool)} stored nominal trials, {est.failures} failures, P = {est.p:.4f}, "
          f"95 % CI {est.low:.4f}-{est.high:.4f}): trials to {args.k} distinct failures over {args.permutations} orders: "
          f"median {np.median(rand):g}, 10-90 % {np.quantile(rand, 0.1):g}-{np.quantile(rand, 0.9):g}, "
          f"{np.mean(~np.isfinite(rand)):.0%} of orders never reach it", flush=True)
    fals = []
    runs = [(f"run {args.mc_run}", pool_df[(pool_df["group"] == grp) & (pool_df["method"] == "falsify")])] \
        if args.with_run else []
    for rep in _repeats(args):
        plan = search_from_data(domain(rep, "falsify", args.falsify_budget, args.planner, args.study),
                                where=f"bench {rep[0]} {rep[1]}")
        out = base / f"falsify-{args.planner}-{rep[0]}{rep[1]}"
        run_search(plan, out, executor="local", workers=args.workers)
        runs.append((f"{rep[0]} {rep[1]}", search_table(out)[0]))
    for name, df in runs:
        n = first_failures(cfg, df, args.k)
        fals.append(n if np.isfinite(n) else np.inf)
        done = df[df["done"]]
        print(f"falsify {name}: {int(done['failed'].sum())} failures in {len(done)} trials, k-th distinct at "
              f"{'> ' + str(len(done)) if not np.isfinite(n) else int(n)}, on {_first_k_terrains(cfg, df, args.k)} "
              "terrain(s)", flush=True)
    fals = np.array(fals)
    print(f"falsify ({args.planner}): trials to {args.k} distinct failures over {len(fals)} repeats: {_spread(fals)}")
    f_med = np.median(fals)
    for name, med in (("random orders of the pool", np.median(rand)), ("bootstrap streams", np.median(boot)),
                      ("negative binomial", nb["p"])):
        print(f"ratio, {name} / falsify median: {med / f_med:.1f}x (over the falsifier's range: "
              f"{med / fals.max():.1f}x-{med / fals.min():.1f}x)")


def is_mode(args, base: Path) -> None:
    """Cross-entropy importance sampling over repeats against the stored Monte Carlo pool (module docstring)."""
    pool_df, pool_plan, grp, pool, mc = _pool(args)
    print(f"Monte Carlo reference ({args.planner}): P = {mc.p:.4f} ({mc.failures}/{mc.n}; 95 % CI "
          f"{mc.low:.4f}-{mc.high:.4f}; rel. error {mc.rel_error:.3f})", flush=True)
    runs = [(f"run {args.mc_run}", pool_df[pool_df["group"] == grp], pool_plan.search)] if args.with_run else []
    for rep in _repeats(args):
        plan = search_from_data(domain(rep, "ce-is", args.ce_budget, args.planner, args.study),
                                where=f"bench {rep[0]} {rep[1]}")
        out = base / f"ce-is-{args.planner}-{rep[0]}{rep[1]}"
        run_search(plan, out, executor="local", workers=args.workers)
        runs.append((f"{rep[0]} {rep[1]}", search_table(out)[0], plan.search))
    ratios, covered = [], 0
    for name, df, cfg in runs:
        groups = sorted(df.loc[df["method"] == "ce-is", "group"].unique())
        e = estimates(df[df["group"] == groups[0]], cfg)[(groups[0], "ce-is")]
        r = mc_trials_ratio(mc, e)
        ratios.append(r)
        covered += bool(e.covers(mc.p))
        print(f"ce-is {name}: P = {e.p:.4f} ({e.failures} failures in its {e.n} final draws, {e.trials} trials), "
              f"95 % interval {e.low:.4f}-{e.high:.4f}, rel. error {e.rel_error:.3f}; MC trials for that rel. error / "
              f"trials: {r:.2f}x; covers MC: {'yes' if e.covers(mc.p) else 'NO'}", flush=True)
    ratios = np.array(ratios)
    print(f"ce-is ({args.planner}) over {len(ratios)} repeats: MC trials for its rel. error / its trials: "
          f"{_spread(ratios)}; {covered} of {len(ratios)} intervals hold the Monte Carlo P")


def bootstrap_trials(cfg, pool, k: int, runs: int, rng: np.random.Generator) -> np.ndarray:
    """Trials to k distinct failures of ``runs`` bootstrap streams: draws with replacement from the
    stored nominal ``pool`` (parameters and outcome together; the study's rule of distinctness)."""
    unit = cfg.unit(pool[list(cfg.keys)].to_numpy(dtype=float))
    failed = pool["failed"].to_numpy(dtype=bool)
    if not failed.any():
        return np.full(runs, np.inf)
    p = failed.mean()
    n = int(min(200_000, 40 * k / p))
    out = np.empty(runs)
    for i in range(runs):
        idx = rng.integers(0, len(pool), n)
        hits = np.nonzero(failed[idx])[0]
        counts = distinct_failures(unit[idx[hits]], np.ones(len(hits), bool), cfg.distinct_distance)
        reach = np.nonzero(counts >= k)[0]
        out[i] = hits[reach[0]] + 1 if len(reach) else np.inf
    return out


def k_trials(k: int, p: float) -> float:
    """Median trials to the k-th failure of independent draws failing with probability p."""
    from scipy import stats

    return float(k + stats.nbinom(k, p).median()) if 0 < p < 1 else float("inf")


def collect(run_dirs: list[str], repeats_csv: Path) -> None:
    """Append the streams of finished repeat run directories to a repeats table (module docstring)."""
    import pandas as pd

    old = pd.read_csv(repeats_csv) if repeats_csv.is_file() else pd.DataFrame()
    new = []
    for d in run_dirs:
        df, plan = search_table(d)
        if not df["done"].all():
            raise SystemExit(f"{d}: unfinished trials; finish the run first")
        planner = plan.groups[0].settings.get("planner", {}).get("name", "straight")
        rep = plan.search.replicate
        for method in df["method"].unique():
            if len(old) and ((old["planner"] == planner) & (old["replicate"] == rep) & (old["method"] == method)).any():
                raise SystemExit(f"{d}: {planner} {method} replicate {rep} is already in {repeats_csv}")
        new.append(df.drop(columns=["cell", "group"]).assign(planner=planner, replicate=rep))
    out = pd.concat([old, *new], ignore_index=True)
    cols = ["planner", "replicate", "method"] + [c for c in out.columns if c not in ("planner", "replicate", "method")]
    out[cols].to_csv(repeats_csv, index=False)
    print(f"{repeats_csv}: {len(out)} rows ({sum(len(n) for n in new)} new)")


def results(folder: Path, study: Path) -> None:
    """The committed figures of a results folder (module docstring)."""
    import pandas as pd

    from offroadbench.search import evaluate as ev
    from offroadbench.search import load_search

    cfg = load_search(folder / "search.toml").search
    analysis = load_search(study).analysis
    run = pd.read_csv(folder / "trials.csv")
    repeats = pd.read_csv(folder / "repeats.csv")
    plan = load_search(folder / "search.toml")
    tables: dict[str, list] = {}
    for grp, g in enumerate(plan.groups):
        planner = ev.group_planner(g)
        fig = ev.results_figures(run, repeats, cfg, analysis, grp, planner, root=ROOT)
        ref = fig["reference"]
        print(f"== {planner}: reference P {ref.p:.4f} (bracket {ref.low:.4f}-{ref.high:.4f}); {ref.how}")
        if "is" in fig:
            print(f"importance sampling over {fig['is_summary']['runs']} runs: {fig['is_summary']}")
        if "check" in fig:
            print(f"reference's bootstrap interval {fig['reference_interval']}; this folder's trials against it: "
                  f"{fig['check']}")
        if "baselines" in fig:
            print(fig["baselines"].to_string())
        for name, key in (("is_repeats.csv", "is"), ("falsifier_baselines.csv", "baselines"),
                          ("falsifier_streams.csv", "falsifier"), ("uniform_streams.csv", "uniform"),
                          ("modes.csv", "modes")):
            if key in fig and len(fig[key]):
                tables.setdefault(name, []).append(fig[key].assign(planner=planner))
        if "check" in fig:
            b, c = ref.boundary, fig["check"]
            tables.setdefault("reference.csv", []).append(pd.DataFrame([{
                "P": ref.p, "bracket low": ref.low, "bracket high": ref.high,
                "bootstrap low": fig["reference_interval"][0], "bootstrap high": fig["reference_interval"][1],
                "boundary low": c["low"], "boundary high": c["high"], "band failed": b.band_failed,
                "band trials": b.band_trials, "boundary trials": b.trials,
                **{f"this folder: {k}": v for k, v in c.items() if k not in ("low", "high")},
                "this folder's own boundary: P": fig["own reference"].p,
                "this folder's own boundary: low": fig["own reference"].boundary.edges()[0],
                "this folder's own boundary: high": fig["own reference"].boundary.edges()[1]}]).assign(planner=planner))
        tables.setdefault("sensitivity.csv", []).append(
            pd.DataFrame([{"parameter": x.key, "eta^2": x.eta2, "threshold": x.threshold, "p": x.p_value,
                           "active": x.active, "draws": x.draws, "failures": x.failures, "source": x.source}
                          for x in fig["sensitivity"]]).assign(planner=planner))
        print(fig["modes"].to_string())
    for name, parts in tables.items():
        t = pd.concat(parts, ignore_index=True)
        t[["planner"] + [c for c in t.columns if c != "planner"]].to_csv(folder / name, index=False)
        print(f"wrote {folder / name}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study", type=Path, default=DEFAULT_STUDY, help="the search study file (default: %(default)s)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="repeats as root seeds")
    ap.add_argument("--replicates", type=int, nargs="+", help="repeats as [search] replicate values (the root seed kept)")
    ap.add_argument("--k", type=int, default=10)
    ap.add_argument("--falsify-budget", type=int, default=64)
    ap.add_argument("--random-budget", type=int, default=320)
    ap.add_argument("--ce-budget", type=int, default=None, help="--method ce-is: trials per stream (default: the study's)")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--planner", default="straight", help="straight (default) or astar")
    ap.add_argument("--keep", help="keep the run directories here (default: a temporary folder)")
    ap.add_argument("--mc-run", help="ratio modes: a finished search's run directory whose random stream is the baseline")
    ap.add_argument("--method", choices=("falsify", "ce-is"), default="falsify", help="ratio modes: what to repeat")
    ap.add_argument("--permutations", type=int, default=2000, help="ratio mode: random orders of the stored pool")
    ap.add_argument("--with-run", action="store_true", help="ratio modes: count the run's own stream as a repeat")
    ap.add_argument("--collect", nargs="+", help="finished repeat run directories to append to --repeats-csv")
    ap.add_argument("--repeats-csv", type=Path, help="--collect: a results folder's repeats.csv")
    ap.add_argument("--results", type=Path, help="a results folder: print and write its committed figures")
    ap.add_argument("--smoke", action="store_true")
    args = ap.parse_args()
    if args.collect:
        if not args.repeats_csv:
            raise SystemExit("--collect needs --repeats-csv")
        collect(args.collect, args.repeats_csv)
        return
    if args.results:
        results(args.results, args.study)
        return
    if args.smoke:
        args.seeds, args.k, args.falsify_budget, args.random_budget = args.seeds[:1], 1, 8, 8
        args.replicates = args.replicates[:1] if args.replicates else None
        args.ce_budget, args.permutations = 16, min(args.permutations, 50)
    base = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="bench-search-"))
    if args.mc_run:
        (is_mode if args.method == "ce-is" else ratio_mode)(args, base)
        return
    found = {"falsify": [], "random": []}
    nominal_failed = []
    for rep in _repeats(args):
        row = []
        for method, budget in (("falsify", args.falsify_budget), ("random", args.random_budget)):
            plan = search_from_data(domain(rep, method, budget, args.planner, args.study), where=f"bench {rep[0]} {rep[1]}")
            out = base / f"{method}-{rep[0]}{rep[1]}"
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
        print(f"{rep[0]} {rep[1]}: " + "; ".join(row), flush=True)
    for method, values in found.items():
        v = np.array(values, dtype=float)
        print(f"{method}: trials to {args.k} distinct failures, median {np.median(v):g} (range {v.min():g}-{v.max():g})")
    est = mc_estimate(nominal_failed)
    print(f"P(failure), nominal sampling pooled: {est.p:.4f} ({est.failures}/{est.n}; 95 % CI {est.low:.4f}-{est.high:.4f})")
    print(f"run directories: {base}")
    if args.smoke:  # the ratio modes too, against this run's own random stream as the pool
        rep = _repeats(args)[0]
        args.mc_run = str(base / f"random-{rep[0]}{rep[1]}")
        ratio_mode(args, base / "ratio")
        is_mode(args, base / "is")


if __name__ == "__main__":
    main()
