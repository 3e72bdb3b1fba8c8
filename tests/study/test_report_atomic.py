"""A killed report leaves the previous complete report (or none), never figures without report.md
(issue 23, Deliver 3)."""

from __future__ import annotations

import multiprocessing
import os

from offroadbench.cli import study as cli_study
from offroadbench.study import run_study, study_from_dict
from offroadbench.study.spec.config import plan_cells

from tests.study.test_run import STUDY, fake_trials


def _killed_report(run_dir, out) -> None:
    import offroadbench.cli._common as common

    calls = []
    real = common.save_figure

    def save_figure(fig, path, dpi=150):
        calls.append(path)
        if len(calls) == 3:
            os._exit(9)
        return real(fig, path, dpi)

    common.save_figure = save_figure
    cli_study.write_report(run_dir, out)
    os._exit(0)


def _kill(run_dir, out) -> int:
    p = multiprocessing.get_context("fork").Process(target=_killed_report, args=(run_dir, out))
    p.start()
    p.join(120)
    return p.exitcode


def listing(d):
    return sorted(q.name for q in d.iterdir()) if d.exists() else []


def test_a_killed_report_leaves_nothing_or_the_old_report(tmp_path):
    study = study_from_dict(STUDY)
    run = tmp_path / "run"
    run_study(study, plan_cells(study), run, executor="inline", trial_fn=fake_trials)
    out = run / "report"
    assert _kill(run, out) == 9
    assert not out.exists()  # a first report killed half way: no report folder
    cli_study.write_report(run, out)
    complete = {n: (out / n).read_bytes() for n in listing(out)}
    assert "report.md" in complete and "fig5_class_areas.png" in complete
    assert _kill(run, out) == 9
    assert {n: (out / n).read_bytes() for n in listing(out)} == complete
    cli_study.write_report(run, out)  # the next report removes what the killed one left
    assert not [n for n in listing(run) if n.startswith(".")]
    assert listing(out) == sorted(complete)
