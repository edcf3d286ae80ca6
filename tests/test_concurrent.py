"""Tests for :mod:`meshwm._concurrent`: a pure function of the faces run beside the block."""

from __future__ import annotations

import threading
import time

import pytest

from meshwm._concurrent import beside
from meshwm.errors import MeshError


def test_the_result_is_the_functions_and_computed_in_another_thread():
    def whose(x: int) -> tuple[int, int]:
        return x * 2, threading.get_ident()

    with beside(whose, 21) as found:
        here = threading.get_ident()
    value, thread = found.result()
    assert value == 42
    assert thread != here


def test_an_error_of_the_function_is_raised_by_result():
    def fails() -> None:
        raise MeshError("the mesh is not edge-manifold")

    with beside(fails) as found, pytest.raises(MeshError, match="edge-manifold"):
        found.result()


@pytest.mark.parametrize("block_raises", [False, True])
def test_leaving_the_block_waits_for_the_function(block_raises):
    done = threading.Event()

    def slow() -> None:
        time.sleep(0.2)
        done.set()

    try:
        with beside(slow):
            if block_raises:
                raise ValueError("the block failed")
    except ValueError:
        assert block_raises
    assert done.is_set()
