"""A program that uses the library (not the CLI) sees no pybullet banner: the engine imports it quietly."""

import subprocess
import sys


def test_the_library_prints_no_pybullet_banner():
    code = ("import offroadbench.sim.engines.pybullet.world as w; import pybullet; "
            "print('pb', w.pb is pybullet)")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert p.stdout == "pb True\n" and "pybullet build time" not in p.stdout + p.stderr
    # the check can fail: a plain import prints it
    plain = subprocess.run([sys.executable, "-c", "import pybullet"], capture_output=True, text=True)
    assert "pybullet build time" in plain.stdout + plain.stderr
