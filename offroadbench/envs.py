"""Gymnasium registration: importing this module registers ``offroadbench/Traverse-v0``.

``gymnasium.make("offroadbench/Traverse-v0")`` after ``import offroadbench.envs``, or in one step
``gymnasium.make("offroadbench.envs:offroadbench/Traverse-v0", terrain="paper-d2.6")``. Keyword
arguments go to :class:`offroadbench.sim.gym_env.TraverseEnv`. Episodes end through the env's own
truncation (the trial runner's timeout rule), so no step limit is registered.
"""

from __future__ import annotations

import gymnasium

__all__ = ["TRAVERSE_ID"]

TRAVERSE_ID = "offroadbench/Traverse-v0"

if TRAVERSE_ID not in gymnasium.registry:
    gymnasium.register(id=TRAVERSE_ID, entry_point="offroadbench.sim.gym_env:TraverseEnv")
