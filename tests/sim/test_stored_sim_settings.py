"""Stored settings replay as they ran: a key whose default changed after a run was stored takes the
value the run had (offroadbench.sim.trial.settings.stored_sim_as_it_ran)."""

from offroadbench.sim.trial.settings import TrialSettings


def test_a_mujoco_table_stored_before_hfield_collision_replays_with_mujoco_s_own_contacts():
    stored = TrialSettings().to_dict()
    del stored["sim"]["mujoco"]["hfield_collision"]  # as every run before issue 41 stored it
    assert TrialSettings.from_dict(stored).sim.mujoco.hfield_collision == "exact"


def test_a_stored_hfield_collision_is_kept():
    for mode in ("mujoco", "exact", "closed_form"):
        stored = TrialSettings().to_dict()
        stored["sim"]["mujoco"]["hfield_collision"] = mode
        assert TrialSettings.from_dict(stored).sim.mujoco.hfield_collision == mode
    assert TrialSettings.from_dict(TrialSettings().to_dict()) == TrialSettings()
