"""One traversal trial and batches of them: pipeline.py (TrialSettings, prepare_terrain,
drive_terrain), runner.py (drive_mission: the tick loop), controller.py (pure pursuit and the speed
profile), vehicle.py (VehicleSpec), skid_steer.py (wheel speeds), batch.py (drive_missions).
Importing this package imports no engine.
"""
