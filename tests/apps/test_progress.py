"""Tests for :mod:`meshwm.apps.progress`: the progress bar of ``meshwm bench`` and ``verify``."""

from __future__ import annotations

import io
import os
import select
import sys

import pytest

from meshwm.apps.progress import ProgressBar, progress_bar


def test_progress_bar():
    stream = io.StringIO()
    bar = ProgressBar(stream, width=10)
    bar(0, 4, "starting")
    bar(1, 4, "first")  # throttled: within 0.1 s of the last draw
    bar(4, 4, "done")
    text = stream.getvalue()
    assert text.startswith("\r  0% [..........] 0/4") and text.endswith("\n")
    assert "100% [##########] 4/4" in text and "first" not in text


def test_a_shorter_line_blanks_the_longer_one():
    stream = io.StringIO()
    bar = ProgressBar(stream, width=4, interval=0.0)
    bar(1, 3, "a long label " * 2)
    bar(2, 3)
    first, second = stream.getvalue().split("\r")[1:]
    assert len(second) == len(first) and second.endswith(" ")
    assert "label" not in second


def test_labels_are_cut():
    line = ProgressBar(io.StringIO(), width=4).line(1, 2, "x" * 100, 1.0)
    assert line.endswith("  " + "x" * 48)


def test_progress_bar_of_a_fixed_total_counts_files():
    stream = io.StringIO()
    show = progress_bar(3, stream)
    for done in (1, 2, 3):
        show(done)
    text = stream.getvalue()
    assert text.startswith("\r 33% [##########....................] 1/3 files, ")
    assert "/s" in text and text.count("\n") == 1 and text.endswith("\n")
    assert "100% [" + "#" * 30 + "] 3/3 files" in text  # the last count is always drawn


@pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs a pseudo-terminal")
def _read_all(fd: int) -> str:
    """Everything written to a pseudo-terminal so far (one read may return only part of it)."""
    chunks = []
    while select.select([fd], [], [], 0.5)[0]:
        try:
            data = os.read(fd, 4096)
        except OSError:  # EIO: the other end is closed and drained
            break
        if not data:
            break
        chunks.append(data)
    return b"".join(chunks).decode()


def test_draws_on_a_terminal():
    master, slave = os.openpty()
    try:
        with open(slave, "w", encoding="utf-8", closefd=False) as tty:
            assert tty.isatty()
            bar = ProgressBar(tty, width=8)
            bar(0, 2, "starting")
            bar(2, 2, "done")
        seen = _read_all(master)
    finally:
        os.close(master)
        os.close(slave)
    assert "  0% [........] 0/2" in seen and "100% [########] 2/2" in seen
    assert seen.rstrip().endswith("done") and seen.endswith("\n")


def test_default_stream_is_stderr(monkeypatch):
    stream = io.StringIO()
    monkeypatch.setattr(sys, "stderr", stream)
    ProgressBar()(1, 1, "done")
    assert stream.getvalue().endswith("done\n")
