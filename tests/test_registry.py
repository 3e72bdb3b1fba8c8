"""The one Registry type: duplicate check, did-you-mean, entry-point plug-ins."""

from importlib import metadata

import pytest

from offroadbench.errors import InputError
from offroadbench.registry import Registry


def test_register_get_names_and_decorator():
    reg = Registry("widget")
    reg.register("alpha", 1)

    @reg.register("beta")
    def beta():
        return 2

    assert reg.get("alpha") == 1 and reg.get("beta") is beta
    assert reg.names() == ["alpha", "beta"] and "alpha" in reg and len(reg) == 2


def test_duplicate_name_is_refused():
    reg = Registry("widget")
    reg.register("alpha", 1)
    with pytest.raises(ValueError, match="registered twice"):
        reg.register("alpha", 2)


def test_unknown_name_suggests_close_matches():
    reg = Registry("planner")
    reg.register("straight", 1)
    reg.register("astar", 2)
    with pytest.raises(InputError, match=r"unknown planner 'straigt'; did you mean 'straight'\? known: astar, straight"):
        reg.get("straigt")
    with pytest.raises(InputError, match=r"unknown planner 'zzz'; known: astar, straight$"):
        reg.get("zzz")


def test_loader_runs_once_before_first_read():
    calls = []
    reg = Registry("widget", loader=lambda: calls.append(1) or reg.register("built-in", 0))
    assert reg.names() == ["built-in"] and reg.get("built-in") == 0
    assert calls == [1]


def test_entry_points_are_loaded_and_adapted(monkeypatch):
    eps = [
        metadata.EntryPoint(name="sqrt", value="math:sqrt", group="offroadbench.test"),
        metadata.EntryPoint(name="broken", value="no_such_module_xyz:thing", group="offroadbench.test"),
    ]

    def fake_entry_points(*, group):
        return [ep for ep in eps if ep.group == group]

    monkeypatch.setattr(metadata, "entry_points", fake_entry_points)
    reg = Registry("function", entry_point_group="offroadbench.test", adapt=lambda name, obj: (name, obj))
    import math

    assert reg.get("sqrt") == ("sqrt", math.sqrt)
    assert "broken" not in reg  # a plug-in that fails to import is skipped with a warning
