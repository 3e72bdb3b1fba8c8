"""What a study is: its config (StudyConfig, the grid, the cells) and the inputs it resolves (terrains, vehicles, soils)."""

from offroadbench.study.spec.cells import CellPlan, build_section, plan_cells
from offroadbench.study.spec.config import GridAxis, SECTIONS, StudyConfig, load_study, study_from_dict, study_id
from offroadbench.study.spec.inputs import COSMETIC_STUDY_KEYS, changed_inputs, changed_study_keys, trial_inputs, vehicle_changed

__all__ = ['CellPlan', 'GridAxis', 'SECTIONS', 'StudyConfig', 'build_section', 'load_study', 'plan_cells', 'study_from_dict', 'study_id', 'COSMETIC_STUDY_KEYS', 'changed_inputs', 'changed_study_keys', 'trial_inputs', 'vehicle_changed']
