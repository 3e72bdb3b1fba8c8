"""The MuJoCo engine (``engine = "mujoco"``): world.py (MuJoCoWorld, the TrialWorld, with its URDF ->
MJCF translation and tyre forces), settings.py (its ``[sim.mujoco]`` table, MuJoCoConfig),
soil_rig.py (the single-wheel soil rig). Importing this package imports no engine; its modules do.
"""

from offroadbench.sim.engine import EngineCapabilities

#: what the MuJoCo engine implements (offroadbench.sim.engine.engine_capabilities)
CAPABILITIES = EngineCapabilities(tyre_models=("bullet", "coulomb", "terramechanics"),
                                  settings=("mujoco",),
                                  soil_rig_module="offroadbench.sim.engines.mujoco.soil_rig")
