"""The pybullet module for this engine's modules, imported without its banner.

The pybullet extension prints "pybullet build time: ..." through C stdio when it is first imported.
The CLI and the study workers import it quietly at start-up; a program that uses the library
directly (a notebook, a script calling ``offroadbench.sim.run_missions``) would see the banner at
the first trial, so this engine's modules import pybullet through here: the first import only,
with file descriptors 1 and 2 pointed at /dev/null for its duration (offroadbench.sim._banner).
"""

from offroadbench.sim._banner import import_pybullet_quietly

import_pybullet_quietly()

import pybullet as pb  # noqa: E402  (already imported, quietly)

__all__ = ["pb"]
