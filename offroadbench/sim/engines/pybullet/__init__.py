"""The PyBullet engine (``engine = "pybullet"``): world.py (World, the TrialWorld), tyres.py (the
``coulomb`` tyre model's contact gathering), soil.py (the ``terramechanics`` tyre model's contact),
soil_rig.py (the single-wheel soil rig). Importing this package imports no engine; its modules do.
"""
