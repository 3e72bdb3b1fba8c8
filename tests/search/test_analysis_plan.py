"""A search's ``[analysis]`` plan: validated, stored with the run, part of its id, read back by the
report; every committed search study has one; the report names the code version and writes HTML."""

import copy
from pathlib import Path

import pytest

from offroadbench.config import load_toml
from offroadbench.errors import InputError
from offroadbench.search import run_search, search_from_data
from tests.search.stand_in import SEARCH

ROOT = Path(__file__).resolve().parents[2]
PLAN = {"estimand": "P(failure) under the nominal speed", "estimator": "ce-is", "interval": "bootstrap-t",
        "reference": "boundary", "boundary_param": "controller.cruise_speed_m_s", "baseline": "uniform",
        "first_k": [1, 3], "stopping": "budget"}


def _data(**analysis):
    data = copy.deepcopy(SEARCH)
    data["analysis"] = {**PLAN, **analysis}
    return data


def test_the_plan_is_read_and_validated():
    plan = search_from_data(_data())
    assert plan.analysis.first_k == (1, 3) and plan.analysis.reference == "boundary"
    for bad, msg in ((dict(estimator="bayes"), "estimator"), (dict(boundary_param="sim.nope"), "not a searched key"),
                     (dict(reference="mc"), "boundary_param is for"), (dict(first_k=[0]), "first_k"),
                     (dict(stopping="sequential"), "stopping"), (dict(colour="red"), "unknown key"),
                     (dict(reference="mc", boundary_param=None, reference_from="x"), "reference_from"),
                     (dict(reference_from=""), "reference_from")):
        with pytest.raises(InputError, match=msg):
            search_from_data(_data(**bad))
    no_estimand = _data()
    del no_estimand["analysis"]["estimand"]
    with pytest.raises(InputError, match="estimand"):
        search_from_data(no_estimand)


def test_the_plan_enters_the_search_id_and_a_search_without_one_keeps_its_id():
    data = copy.deepcopy(SEARCH)
    assert search_from_data(data).search_id == search_from_data(copy.deepcopy(SEARCH)).search_id
    assert search_from_data(_data()).search_id != search_from_data(data).search_id
    assert search_from_data(_data(first_k=[1, 5])).search_id != search_from_data(_data()).search_id


@pytest.mark.parametrize("name", sorted(p.name for p in (ROOT / "experiments").glob("*.toml")
                                        if "search" in load_toml(p)))
def test_every_committed_search_study_has_an_analysis_plan(name):
    from offroadbench.search import load_search

    plan = load_search(ROOT / "experiments" / name)
    assert plan.analysis is not None, f"experiments/{name} has no [analysis] table"


def test_the_report_reads_the_stored_plan_names_the_code_and_writes_html(tmp_path):
    from offroadbench.cli import main
    from offroadbench.search.report import build_search_report
    from tests.search.test_pipeline_estimates import speed_trials

    data = _data()
    data["search"].update(methods=["falsify", "random", "ce-is"], budget=40, mc_budget=200, batch_size=20,
                          ce_stage_size=10)
    data["search"]["params"][0]["mean"] = 1.4  # P(speed > 1.75) about 0.1: enough failures to see the speed act
    plan = search_from_data(data)
    # the stored search text (`search run` stores the file's text): the report reads the plan from it
    text = "[analysis]\n" + "".join(f"{k} = {v!r}\n".replace("'", '"') for k, v in data["analysis"].items())
    run_search(plan, tmp_path / "run", executor="inline", trial_fn=speed_trials, source_text=text)
    rep = build_search_report(tmp_path / "run")
    assert "The analysis plan" in rep.markdown and "P(failure) under the nominal speed" in rep.markdown
    assert "- code: " in rep.markdown and ("commit `" in rep.markdown or "not a git checkout" in rep.markdown)
    assert "## Failure modes" in rep.markdown and "## The falsifier against its baselines" in rep.markdown
    assert {"modes.csv", "baselines.csv", "sensitivity.csv", "is_at_reference.csv"} <= set(rep.tables)
    assert rep.tables["sensitivity.csv"].set_index("parameter").loc["controller.cruise_speed_m_s", "active"]
    assert main(["search", "report", str(tmp_path / "run"), "--out", str(tmp_path / "rep"), "--html"]) == 0
    page = (tmp_path / "rep" / "report.html").read_text()
    assert page.startswith("<!DOCTYPE html>") and "data:image/png;base64," in page and "study replay" in page
