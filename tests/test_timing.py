"""`bandopt.timing.best_time`: one untimed warm-up, the least of `repeat`
timed calls, JAX results waited for."""

import pytest

from bandopt.timing import best_time


def test_warm_up_then_repeat_calls_and_the_least_time():
    calls = []
    assert best_time(lambda: calls.append(1), repeat=4) >= 0.0
    assert len(calls) == 5


def test_a_returned_jax_array_is_waited_for():
    waited = []

    class Result:
        def block_until_ready(self):
            waited.append(1)
            return self

    best_time(Result, repeat=2)
    assert len(waited) == 2  # the timed calls only, not the warm-up


def test_repeat_must_be_positive():
    with pytest.raises(ValueError, match="repeat must be >= 1"):
        best_time(lambda: None, repeat=0)
