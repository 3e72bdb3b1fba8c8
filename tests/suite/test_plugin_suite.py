"""A plug-in planner runs the suite as a shipped one does: the example package (examples/) is
installed with pip into a temporary folder and ``suite run --planner via`` scores it."""

import json
import os
import subprocess
import sys


def test_an_installed_plugin_planner_runs_the_suite_and_gets_a_card(tmp_path, example_plugin_site):
    from .conftest import suite_text

    site = example_plugin_site
    (tmp_path / "tiny-v1.toml").write_text(suite_text())
    code = "import sys; from offroadbench.cli import main; sys.exit(main(sys.argv[1:]))"
    args = ["suite", "run", "--suite", "tiny-v1.toml", "--planner", "via", "--out", "via", "--executor", "inline"]
    env = dict(os.environ, PYTHONPATH=str(site))
    p = subprocess.run([sys.executable, "-c", code, *args], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    card = json.loads((tmp_path / "via" / "score.json").read_text())
    assert card["planner"] == "via" and len(card["tasks"]) == 6 and card["suite"]["name"] == "tiny-v1"
    assert "--planner via" in card["command"]
    # without the package the name is unknown: one line, exit 2, nothing run
    bare = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    p = subprocess.run([sys.executable, "-c", code, *args[:-4], "--out", "bare"], cwd=tmp_path, env=bare,
                       capture_output=True, text=True)
    assert p.returncode == 2 and "unknown planner or policy 'via'" in p.stderr and not (tmp_path / "bare").exists()
