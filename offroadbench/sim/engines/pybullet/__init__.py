"""The PyBullet engine (``engine = "pybullet"``): world.py (World, the TrialWorld), tyres.py (the
``coulomb`` tyre model's contact gathering), soil.py (the ``terramechanics`` tyre model's contact),
soil_rig.py (the single-wheel soil rig). Importing this package imports no engine; its modules do.
"""

from offroadbench.sim.engine import EngineCapabilities

#: what the PyBullet engine implements (offroadbench.sim.engine.engine_capabilities)
CAPABILITIES = EngineCapabilities(tyre_models=("bullet", "coulomb", "terramechanics"),
                                  settings=("heightfield_tile_cells", "cone_friction"),
                                  soil_rig_module="offroadbench.sim.engines.pybullet.soil_rig")
