"""`.ci/run` proves what the README says and runs every test that needs an extra it installs later."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CI = (ROOT / ".ci" / "run").read_text()


def test_ci_runs_the_readmes_test_command():
    readme = (ROOT / "README.md").read_text()
    commands = re.findall(r"```bash\n(.*?)\n```", readme, flags=re.S)
    test_cmd = next(c for c in commands if "pytest" in c)
    assert test_cmd in CI.splitlines()


def test_every_test_that_needs_mujoco_warp_is_in_the_ci_warp_step():
    """The README's command runs without the `warp` extra, so a test that skips without mujoco_warp runs
    only where `.ci/run` installs it and names its file."""
    step = next(line for line in CI.splitlines() if '".[warp]"' in line and "pytest" in line)
    needs = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "tests").rglob("test_*.py")
                   if re.search(r"""importorskip\(["']mujoco_warp["']\)|find_spec\(["']mujoco_warp["']\)""",
                                p.read_text()))
    assert len(needs) >= 4
    assert [n for n in needs if n not in step.split()] == []
