"""The plug-in API end to end: the example package under examples/ is built and installed with pip
(into a temporary directory, not the source tree), and its planner and policy run through
``offroadbench drive --planner`` and ``offroadbench study run``; a failed trial replays bit for bit."""

import os
import subprocess
import sys

import pytest


STUDY = """
[study]
name = "plugins"
recipe = "paper-d2.6"
root_seed = 3
terrains_per_cell = 1
missions_per_terrain = 2
telemetry = "all"

[grid]
"planner.name" = ["straight", "via", "cautious"]

[recipe_overrides]
"grid.rows" = 161
"grid.cols" = 161
"layers.base.relief_m" = 1.5

[roughness]
border_m = 1.0

[missions]
length_m = 4.0
border_m = 1.0
"""


@pytest.fixture(scope="module")
def installed(tmp_path_factory, example_plugin_site):
    """A working folder, and an env that finds the example package pip installed into a target folder
    (tests/conftest.py)."""
    tmp = tmp_path_factory.mktemp("plugin")
    env = dict(os.environ, PYTHONPATH=str(example_plugin_site))
    return tmp, env


def _cli(args, env, cwd):
    code = "import sys; from offroadbench.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *args], env=env, cwd=cwd, capture_output=True, text=True)


def test_installed_planner_drives_with_drive_planner(installed):
    tmp, env = installed
    args = ["drive", "paper-d2.6", "--set", "grid.rows=301", "--set", "grid.cols=301", "--length-m", "4",
            "--missions", "1", "--seed", "1", "--planner", "via"]
    p = _cli(args, env, tmp)
    assert p.returncode == 0, p.stderr
    assert "planner via" in p.stdout and "success rate" in p.stdout
    p = _cli([*args[:-1], "cautious"], env, tmp)
    assert p.returncode == 0 and "planner cautious" in p.stdout
    # without the package on the path the name is unknown: exit 2 and a did-you-mean line
    bare = dict(os.environ)
    bare.pop("PYTHONPATH", None)
    p = _cli([*args[:-1], "via"], bare, tmp)
    assert p.returncode == 2 and "unknown planner or policy 'via'" in p.stderr


def test_installed_planner_and_policy_run_in_a_study_and_a_trial_replays(installed):
    tmp, env = installed
    (tmp / "plugins.toml").write_text(STUDY)
    p = _cli(["study", "run", "plugins.toml", "--out", "run", "--executor", "inline"], env, tmp)
    assert p.returncode == 0, p.stderr
    import pandas as pd

    from offroadbench.study import load

    df = load(tmp / "run")
    assert sorted(df["planner"].unique()) == ["cautious", "straight", "via"]
    assert len(df) == 6
    # every planner drove the same missions
    ends = df.groupby("mission")[["start_x_m", "start_y_m", "goal_x_m", "goal_y_m"]].nunique()
    assert (ends == 1).all().all()
    row = df[df["planner"] == "via"].iloc[0]
    assert (tmp / "run" / "telemetry" / f"cell{row['cell']}_terrain0_mission{row['mission']}_path.parquet").is_file()
    p = _cli(["study", "replay", "run", "--cell", str(row["cell"]), "--terrain", "0", "--mission", str(row["mission"]),
              "--plot"], env, tmp)
    assert p.returncode == 0, p.stderr + p.stdout
    assert "identical to the stored row: yes" in p.stdout
    assert (tmp / "run" / "replays" / f"cell{row['cell']}_terrain0_mission{row['mission']}.png").stat().st_size > 0
    assert isinstance(pd.read_parquet(tmp / "run" / "replays" / f"cell{row['cell']}_terrain0_mission{row['mission']}.parquet"),
                      pd.DataFrame)
    assert (tmp / "run" / "report" / "report.md").is_file()
