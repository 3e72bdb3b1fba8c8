"""``study run``, ``search run`` and ``suite run`` take the same executor options with the same checks
(offroadbench.cli._runs): a bad one is exit 2, one stderr line naming the flag and what is allowed,
refused before any trial runs, and no run directory made. Parametrised over the three commands so
that they cannot drift apart again."""

from __future__ import annotations

from pathlib import Path

import pytest

from offroadbench.cli import main
from tests.conftest import TINY_STUDY_TOML
from tests.suite.conftest import suite_text

SEARCH = Path(__file__).parents[1] / "search" / "small-search.toml"


@pytest.fixture
def inputs(tmp_path, monkeypatch):
    """A study TOML, a search TOML and a suite TOML in a fresh working directory, and the three
    runners replaced by ones that fail the test: a refused option never reaches them."""
    from offroadbench import search, study, suite

    (tmp_path / "study.toml").write_text(TINY_STUDY_TOML.format(name="options", root_seed=3, terrains=1, missions=1))
    (tmp_path / "search.toml").write_text(SEARCH.read_text())
    (tmp_path / "tiny-v1.toml").write_text(suite_text())

    def ran(*args, **kwargs):
        raise AssertionError("a trial would run")

    for module, name in ((study, "run_study"), (search, "run_search"), (suite, "run_suite")):
        monkeypatch.setattr(module, name, ran)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _exit(argv: list[str]) -> int:
    """The exit status of the console script (argparse's refusals are a SystemExit)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


#: the command line of each command that runs trials, before the options
COMMANDS = {
    "study": ["study", "run", "study.toml"],
    "search": ["search", "run", "search.toml"],
    "suite": ["suite", "run", "--suite", "tiny-v1.toml", "--planner", "astar"],
}

#: (id, options, what the one line must hold: the flag, then what is allowed)
BAD = [
    ("scheduler-local", ["--scheduler", "tcp://127.0.0.1:1"], ["--scheduler", "needs --executor dask, not local"]),
    ("scheduler-inline", ["--executor", "inline", "--scheduler", "tcp://127.0.0.1:1"],
     ["--scheduler", "needs --executor dask, not inline"]),
    ("timeout-inline", ["--executor", "inline", "--trial-timeout-s", "5"],
     ["--trial-timeout-s", "applies to --executor local and dask, not inline"]),
    ("timeout-batched", ["--executor", "batched", "--trial-timeout-s", "5"],
     ["--trial-timeout-s", "applies to --executor local and dask, not batched"]),
    *[(f"timeout-{text}", ["--trial-timeout-s", text], ["--trial-timeout-s", "must be a number of seconds > 0 and at "
                                                        f"most 2.592e+06 (30 days), got '{text}'"])
      for text in ("0", "-1", "abc", "nan", "inf", "1e10", "")],
    ("timeout-dask-1e10", ["--executor", "dask", "--trial-timeout-s", "1e10"], ["--trial-timeout-s", "30 days"]),
    *[(f"workers-{text}", ["--workers", text], ["--workers", "must be an integer >= 1"]) for text in ("0", "-2", "two")],
    ("executor-unknown", ["--executor", "nosuch"], ["--executor", "invalid choice", "local"]),
    ("timeout-below-the-shortest-trial", ["--trial-timeout-s", "1e-6"],
     ["--trial-timeout-s", "shortest possible trial", "give at least that"]),
]


@pytest.mark.parametrize("command", sorted(COMMANDS))
@pytest.mark.parametrize("case, options, words", BAD, ids=[c for c, _, _ in BAD])
@pytest.mark.parametrize("out", [True, False], ids=["out", "default-out"])
def test_a_bad_run_option_is_one_line_exit_2_and_makes_no_run_directory(inputs, capsys, command, case, options, words,
                                                                         out):
    before = sorted(p.name for p in inputs.iterdir())
    argv = [*COMMANDS[command], *options, *(["--out", "r"] if out else [])]
    assert _exit(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.endswith("\n") and "Traceback" not in err, err
    at = 0
    for word in words:  # the flag first, then what is allowed
        at = err.find(word, at)
        assert at >= 0, f"{word!r} not in order in: {err}"
    assert sorted(p.name for p in inputs.iterdir()) == before  # no run directory, no runs/


def test_the_three_commands_take_the_same_run_options():
    from offroadbench.cli import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command").choices
    shared = ("--out", "--workers", "--executor", "--scheduler", "--trial-timeout-s", "--retry-faults", "--force")
    runs = {}
    for name in COMMANDS:
        run = next(a for a in sub[name]._actions if a.dest == f"{name}_command").choices["run"]
        runs[name] = {s: a for a in run._actions for s in a.option_strings}
        assert set(shared) <= set(runs[name]), name
        timeout = runs[name]["--trial-timeout-s"].help
        assert "30 days" in timeout and "shortest possible trial" in timeout, name
    study = runs.pop("study")
    for name, options in runs.items():
        assert options["--trial-timeout-s"].type is study["--trial-timeout-s"].type, name
        for flag in ("--workers", "--executor", "--scheduler"):
            assert (options[flag].help, options[flag].choices, options[flag].default) == \
                (study[flag].help, study[flag].choices, study[flag].default), (name, flag)


@pytest.mark.parametrize("command", ["study", "search", "suite"])
def test_a_default_run_directory_name_that_is_no_plain_file_name_is_refused(inputs, capsys, command):
    """The default run directory runs/NAME (runs/suite/SUITE-TIER-PLANNER) is refused in one line
    when its name could not be one folder; --out is the way out."""
    if command == "suite":
        (inputs / "tiny-v1.toml").write_text((inputs / "tiny-v1.toml").read_text().replace(
            'name = "tiny-v1"', 'name = "tiny\\tv1"'))
    else:
        path = inputs / f"{command}.toml"
        text = path.read_text()
        assert text.count('name = "') >= 1
        head, _, rest = text.partition('name = "')
        path.write_text(head + 'name = "a\\nb' + rest[rest.index('"'):])
    before = sorted(p.name for p in inputs.iterdir())
    assert _exit(COMMANDS[command]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot name the run directory" in err and "give --out" in err, err
    assert sorted(p.name for p in inputs.iterdir()) == before


def test_the_faults_of_a_suite_s_categories_are_added_per_kind(tmp_path):
    from offroadbench.cli._runs import fault_lines, run_totals
    from offroadbench.study.session import FaultCount, RunSummary

    a = RunSummary(tmp_path / "a", total=4, done=3, ran=2, successes=1, wall_s=1.5, faults=1,
                   new_faults=(FaultCount("timeout", 1, "ran longer than 5 s"),))
    b = RunSummary(tmp_path / "b", total=6, done=2, ran=0, successes=0, wall_s=2.5, faults=4,
                   new_faults=(FaultCount("thrown", 1, "thrown while it settled"),
                               FaultCount("timeout", 3, "ran longer than 5 s (b)")))
    t = run_totals([a, b], tmp_path)
    assert (t.total, t.done, t.ran, t.successes, t.wall_s, t.faults, t.faulted) == (10, 5, 2, 1, 4.0, 5, 5)
    assert fault_lines(t, tmp_path) == ["faults of this run: 4 x ran longer than 5 s",
                                        "faults of this run: 1 x thrown while it settled"]
    assert fault_lines(b, tmp_path, outcomes_needed=False) == ["faults of this run: 1 x thrown while it settled",
                                                               "faults of this run: 3 x ran longer than 5 s (b)"]
    from offroadbench.errors import StudyError

    with pytest.raises(StudyError, match="every trial of this run faulted"):
        fault_lines(b, tmp_path)
