"""The falsifier's local pattern search (offroadbench.search.falsifier._local_moves)."""

import numpy as np

from offroadbench.search.falsifier import Batch, _local_moves
from offroadbench.search.space import search_from_dict

TABLE = {"startup_trials": 1, "local_step": 0.2, "distinct_distance": 0.1, "batch_size": 4,
         "params": [{"key": "controller.cruise_speed_m_s", "low": 0.0, "high": 1.0},
                    {"key": "recipe.layers.base.D_high", "low": 2.0, "high": 3.0}]}


def test_no_moves_before_a_failure():
    cfg = search_from_dict(TABLE)
    history = [Batch("falsify", np.array([[0.5, 2.5]]), np.zeros((1, 2)), np.array([0.3]), ((1, 2),))]
    assert _local_moves(cfg, history, 3) == []


def test_moves_keep_the_failures_terrain_and_step_one_parameter():
    cfg = search_from_dict(TABLE)
    history = [Batch("falsify", np.array([[0.5, 2.5], [0.95, 2.5]]), np.zeros((2, 2)), np.array([0.3, -0.5]),
                     ((1, 2), (3, 4)))]
    moves = _local_moves(cfg, history, 10)
    assert all(s == (3, 4) for _, s in moves)
    got = sorted(tuple(np.round(u, 9)) for u, _ in moves)
    # the + speed move is clipped at the range's end, 0.05 away: not distinct, so not proposed
    assert got == sorted([(0.75, 0.5), (0.95, 0.7), (0.95, 0.3)])


def test_a_parameter_whose_moves_kept_failures_is_moved_first():
    cfg = search_from_dict(TABLE)
    # failure at (0.5, 0.5) in range units; moving speed lost it twice, moving D_high kept it once
    x = np.array([[0.5, 2.5], [0.7, 2.5], [0.3, 2.5], [0.5, 2.7]])
    history = [Batch("falsify", x, np.zeros((4, 2)), np.array([-0.5, 0.2, 0.2, -0.4]), ((1, 1),) * 4)]
    moves = _local_moves(cfg, history, 2)
    firsts = [np.round(u, 9).tolist() for u, _ in moves]
    # D_high moves first (kept 1 of 1 against 0 of 2), from the deepest failure, + before -
    assert firsts == [[0.5, 0.3], [0.5, 0.9]]


def test_fresh_terrain_moves_leave_the_terrain_to_the_stream_and_stay_distinct_from_every_point():
    cfg = search_from_dict({**TABLE, "local_terrain": "fresh"})
    # a failure at (0.5, 0.5) on terrain (3, 4); a point tried on another terrain sits where its + speed move would go
    history = [Batch("falsify", np.array([[0.5, 2.5], [0.7, 2.5]]), np.zeros((2, 2)), np.array([-0.5, 0.3]),
                     ((3, 4), (5, 6)))]
    moves = _local_moves(cfg, history, 10)
    assert all(s is None for _, s in moves)  # the runner draws the stream's next terrain for them
    got = sorted(tuple(np.round(u, 9)) for u, _ in moves)
    assert got == sorted([(0.3, 0.5), (0.5, 0.7), (0.5, 0.3)])  # (0.7, 0.5) was tried, on another terrain
