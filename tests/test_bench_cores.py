"""bench/common.py's ``--cpus N`` picks the N least busy cores (two benchmarks started with
``--cpus 1`` on one machine used to both pin core 0 and share it)."""

import os
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
import common  # noqa: E402


def test_the_least_busy_cores_are_picked():
    busy = {0: 0.95, 1: 0.30, 2: 0.50, 3: 0.01}
    assert common.pick_cores(1, busy, busy) == [3]
    assert common.pick_cores(2, busy, busy) == [1, 3]
    assert common.pick_cores(3, busy, busy) == [1, 2, 3]
    # busy fractions are compared to one decimal (0.02 and 0.01 both 0.0): the lower core wins
    assert common.pick_cores(1, {0, 1}, {0: 0.02, 1: 0.01}) == [0]


def test_ties_and_unknown_load_keep_the_first_cores():
    assert common.pick_cores(1, {0, 1}, {0: 0.0, 1: 0.0}) == [0]
    assert common.pick_cores(2, {0, 1, 2}, None) == [0, 1]
    assert common.pick_cores(5, {0, 1}, None) == [0, 1]  # never more than allowed
    assert common.pick_cores(0, {4, 7}, None) == [4]  # at least one


@pytest.mark.skipif(not os.path.exists("/proc/stat"), reason="/proc/stat is Linux's")
def test_busy_fractions_are_fractions_of_the_allowed_cores():
    cores = os.sched_getaffinity(0)
    busy = common._busy_fractions(cores, interval=0.05)
    assert set(busy) == set(cores)
    assert all(0.0 <= b <= 1.0 for b in busy.values())
