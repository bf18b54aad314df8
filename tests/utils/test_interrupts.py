"""Stop signals held back by `signals_deferred` (for code a Python exception must not enter,
such as torch's C++ initialisation) are raised when the block is left."""

from __future__ import annotations

import os
import signal

import pytest

from ariel.utils.interrupts import Interrupted, signals_deferred, stop_on_signals


def test_a_signal_within_signals_deferred_is_raised_on_leaving() -> None:
    reached = []
    with stop_on_signals(), pytest.raises(Interrupted) as stopped:
        with signals_deferred():
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(1000):  # Python runs the handler between bytecodes
                pass
            reached.append("end of the block")
        reached.append("after the block")
    assert reached == ["end of the block"]
    assert stopped.value.signum == signal.SIGTERM


def test_nested_blocks_raise_when_the_outermost_is_left() -> None:
    reached = []
    with stop_on_signals(), pytest.raises(Interrupted), signals_deferred():
        with signals_deferred():
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(1000):
                pass
        reached.append("inner left")
    assert reached == ["inner left"]


def test_outside_stop_on_signals_nothing_is_raised() -> None:
    with signals_deferred():
        pass  # no signal noted: leaving raises nothing


def test_a_signal_ignored_or_handled_elsewhere_is_left_so() -> None:
    """Under ``nohup`` SIGHUP is ignored: a closed terminal must not stop the run. A handler
    of the caller's own keeps the signal; an inner block leaves the outer one's handlers."""
    seen: list[int] = []
    before = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    term_before = signal.signal(signal.SIGTERM, lambda signum, frame: seen.append(signum))
    try:
        with stop_on_signals():
            assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGHUP)  # ignored: nothing happens
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(1000):
                pass
        assert seen == [signal.SIGTERM]
    finally:
        signal.signal(signal.SIGHUP, before)
        signal.signal(signal.SIGTERM, term_before)
    with stop_on_signals():
        outer = signal.getsignal(signal.SIGTERM)
        with stop_on_signals():
            assert signal.getsignal(signal.SIGTERM) is outer
        assert signal.getsignal(signal.SIGTERM) is outer  # not put back by the inner block


def test_a_signal_taken_while_a_plugin_loads_is_the_interrupt_not_a_broken_plugin() -> None:
    """ctypes wraps an exception raised in a conversion ("ArgumentError: argument 1:
    Interrupted: 15"): a SIGTERM while a plugin's module loaded was said as "could not load
    controller", exit 2, and the run was left "stopped (killed?)"."""
    import ctypes

    from ariel.plugins import controllers

    def load() -> None:
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(1000):  # Python runs the handler between bytecodes
                pass
        except Interrupted as exc:
            raise ctypes.ArgumentError(f"argument 1: Interrupted: {exc.signum}") from None

    with stop_on_signals(), pytest.raises(Interrupted) as stopped:
        controllers._load("loading", load, lambda: "a test")
    assert stopped.value.signum == signal.SIGTERM
