"""The README's library example runs as written (a user's first ``import`` must not fail)."""

from __future__ import annotations

import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def _library_example() -> str:
    text = README.read_text()
    head = text.index("Library entry points")
    m = re.compile(r"```python\n(.*?)```", re.S).search(text, head)
    assert m, "no python block after 'Library entry points' in README.md"
    return m.group(1)


def test_readme_library_example_runs(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    code = _library_example()
    exec(compile(code, f"{README}:library example", "exec"), {"__name__": "__readme__"})
    assert (tmp_path / "terrain.png").stat().st_size > 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 3 and "'low'" in lines[0]  # the fractions, then one line per trial
