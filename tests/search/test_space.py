"""The [search] table: validation with messages that name the key, the nominal transforms, and
the CLI's one-line errors."""

import copy

import numpy as np
import pytest
from scipy import stats

from offroadbench.cli import main
from offroadbench.errors import InputError
from offroadbench.search import search_from_data
from offroadbench.search.space import SearchParam
from tests.search.stand_in import SEARCH


def test_a_truncated_normal_nominal_maps_standard_normals_to_its_distribution():
    p = SearchParam(key="recipe.layers.base.D_high", low=2.3, high=2.6, nominal="normal", mean=2.4, sd=0.1)
    z = np.random.default_rng(0).standard_normal(20000)
    x = p.from_z(z)
    assert x.min() >= 2.3 and x.max() <= 2.6
    truth = stats.truncnorm((2.3 - 2.4) / 0.1, (2.6 - 2.4) / 0.1, loc=2.4, scale=0.1)
    assert stats.kstest(x, truth.cdf).pvalue > 0.01
    assert np.allclose(p.to_z(x), z, atol=1e-6)


def test_a_uniform_nominal_is_uniform_on_its_range():
    p = SearchParam(key="missions.length_m", low=4.0, high=8.0)
    x = p.from_z(np.random.default_rng(1).standard_normal(20000))
    assert stats.kstest((x - 4.0) / 4.0, "uniform").pvalue > 0.01


@pytest.mark.parametrize("change, message", [
    ({"low": 3.0, "high": 2.0}, r"SearchParam.high = 2.0 is out of range"),
    ({"nominal": "lognormal"}, r"SearchParam.nominal = 'lognormal' is not known; allowed: uniform, normal"),
    ({"key": "soil.name"}, r"must start with recipe or one of"),
    ({"sd": -1.0}, r"SearchParam.sd = -1.0 is out of range"),
    ({"wide": 1}, r"unknown key\(s\) wide"),
])
def test_bad_params_are_refused_naming_the_key(change, message):
    data = copy.deepcopy(SEARCH)
    data["search"]["params"][0].update(change)
    with pytest.raises(InputError, match=message):
        search_from_data(data)


@pytest.mark.parametrize("change, message", [
    ({"budget": 0}, r"SearchConfig.budget = 0 is out of range"),
    ({"methods": ["falsify", "grid"]}, r"SearchConfig.methods = 'grid' is not known"),
    ({"sampler": "bayes"}, r"SearchConfig.sampler = 'bayes' is not known; allowed: tpe, cmaes"),
    ({"ce_quantile": 0.9}, r"SearchConfig.ce_quantile = 0.9 is out of range"),
    ({"params": []}, r"needs at least one"),
    ({"budgt": 3}, r"unknown key\(s\) budgt; known keys: params, methods, budget"),
    # the local search's and the estimators' own settings
    ({"local_step": 0.05}, "at least distinct_distance"),
    ({"local_step": 0.2, "sampler": "cmaes"}, "needs sampler = 'tpe'"),
    ({"mc_budget": 0}, "mc_budget"),
    ({"ce_budget": 0}, "ce_budget"),
    ({"ce_initial_sd": 0.2}, "ce_initial_sd = 0.2 is out of range"),
    ({"ce_min_failures": -1}, "ce_min_failures"),
    ({"local_terrain": "other"}, "local_terrain = 'other' is not known"),
])
def test_bad_search_tables_are_refused(change, message):
    data = copy.deepcopy(SEARCH)
    data["search"].update(change)
    with pytest.raises(InputError, match=message):
        search_from_data(data)


def test_a_searched_key_the_recipe_does_not_have_is_refused_before_any_trial():
    data = copy.deepcopy(SEARCH)
    data["search"]["params"][1]["key"] = "recipe.layers.nolayer.D_high"
    with pytest.raises(InputError, match="no layer 'nolayer'"):
        search_from_data(data)


def test_a_value_a_settings_table_refuses_is_caught_at_the_range_ends():
    data = copy.deepcopy(SEARCH)
    data["search"]["params"][0].update(low=-1.0, nominal="uniform", mean=None, sd=None)
    data["search"]["params"][0] = {k: v for k, v in data["search"]["params"][0].items() if v is not None}
    with pytest.raises(InputError, match="cruise_speed_m_s"):
        search_from_data(data)


def test_study_counts_are_not_search_keys():
    data = copy.deepcopy(SEARCH)
    data["study"]["terrains_per_cell"] = 4
    with pytest.raises(InputError, match="terrains_per_cell: not for a search"):
        search_from_data(data)


def test_cli_errors_are_one_line_with_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[study]\nname = "x"\nrecipe = "paper-d2.45"\nroot_seed = 0\n')
    assert main(["search", "run", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no [search] table" in err
    assert main(["search", "report", str(tmp_path)]) == 2
    assert "not a search run directory" in capsys.readouterr().err


def test_each_method_has_its_budget():
    data = copy.deepcopy(SEARCH)
    data["search"].update(budget=10, mc_budget=30, ce_budget=20)
    cfg = search_from_data(data).search
    assert [cfg.method_budget(m) for m in ("falsify", "random", "ce-is")] == [10, 30, 20]
    # search run --budget N: every method N (a quick look at a big study runs N trials a stream, not its mc_budget)
    assert [cfg.method_budget(m, 4) for m in ("falsify", "random", "ce-is")] == [4, 4, 4]
