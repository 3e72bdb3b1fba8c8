"""A real failure search (PyBullet) on 12.8 m maps with 6 m missions: `search run` finds failures,
writes its report, a found failure replays bit for bit with `study replay`, and a search
interrupted in the middle of a batch resumes with the identical proposals and trials."""

import sqlite3
from pathlib import Path

import pytest

from offroadbench.cli import main
from offroadbench.search import load_search, run_search
from offroadbench.sim import drive_terrain

SMALL = Path(__file__).with_name("small-search.toml")


def _table(run_dir):
    con = sqlite3.connect(f"file:{run_dir / 'study.sqlite'}?mode=ro", uri=True)
    try:
        return (con.execute("SELECT cell, grp, method, batch, slot, stage, x, z FROM search_trials ORDER BY cell").fetchall(),
                con.execute("SELECT cell, terrain_seed, mission_seed, row FROM trials ORDER BY cell").fetchall())
    finally:
        con.close()


@pytest.fixture(scope="module")
def searched(tmp_path_factory):
    out = tmp_path_factory.mktemp("small") / "run"
    assert main(["search", "run", str(SMALL), "--out", str(out), "--workers", "2"]) == 0
    return out


@pytest.mark.timeout(600)
def test_search_run_finds_failures_and_reports_them(searched):
    proposals, rows = _table(searched)
    assert len(proposals) == len(rows) == 12
    failed = [r for r in rows if '"success": false' in r[3]]
    assert failed, "the falsifier found no failure in 12 trials"
    text = (searched / "report" / "report.md").read_text()
    assert "## Worst failures" in text and "study replay" in text
    assert (searched / "report" / "failures_vs_trials.png").is_file()


@pytest.mark.timeout(600)
def test_a_found_failure_replays_identically(searched, capsys):
    from offroadbench.search.report import search_table

    df, _ = search_table(searched)
    worst = df[df["failed"]].sort_values("margin").iloc[0]
    assert main(["study", "replay", str(searched), "--cell", str(int(worst["cell"])), "--terrain", "0",
                 "--mission", "0"]) == 0
    assert "identical to the stored row: yes" in capsys.readouterr().out


@pytest.mark.timeout(600)
def test_an_interrupted_real_search_resumes_identically(searched, tmp_path):
    count = {"n": 0}

    def interrupted(prepared, settings):
        for rec in drive_terrain(prepared, settings):
            count["n"] += 1
            if count["n"] > 6:  # the middle of the second batch of 4
                raise KeyboardInterrupt
            yield rec

    plan = load_search(SMALL)
    with pytest.raises(KeyboardInterrupt):
        run_search(plan, tmp_path, executor="inline", trial_fn=interrupted)
    assert len(_table(tmp_path)[1]) == 6
    summary = run_search(plan, tmp_path, executor="local", workers=2)
    assert summary.ran == 6
    assert _table(tmp_path) == _table(searched)


@pytest.mark.timeout(600)
def test_the_search_benchmark_runs_in_its_smoke_mode(tmp_path):
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    out = subprocess.run([sys.executable, str(root / "benchmarks" / "bench_search.py"), "--smoke", "--workers", "1",
                          "--keep", str(tmp_path)],
                         capture_output=True, text=True, timeout=500, cwd=root)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "falsify: trials to 1 distinct failures" in out.stdout
    assert "P(failure), nominal sampling pooled" in out.stdout
    assert "ratio, bootstrap streams / falsify median" in out.stdout  # the ratio mode against that pool
    assert "intervals hold the Monte Carlo P" in out.stdout  # and the importance-sampling repeats
