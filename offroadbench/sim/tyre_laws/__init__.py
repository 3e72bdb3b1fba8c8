"""Engine-neutral tyre force laws: coulomb.py (the ``coulomb`` model's bristle friction) and
terramechanics.py (the Wong-Reece soft-soil forces and their tables). No physics engine here: each
engine gathers the contact state a law needs and applies the forces it returns.
"""
