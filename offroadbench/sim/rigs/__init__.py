"""Diagnostic rigs: vehicle_check.py (``vehicle check``: the vehicle against its own physics) and
soil_check.py (``soil check``: one wheel on a soil against the Wong-Reece integrals).
"""
