"""Activation functions of CPPN nodes, by name (upstream's set; numpy, element-wise)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["ACTIVATION_FUNCTIONS", "DEFAULT_ACTIVATION", "gaussian", "relu", "sigmoid", "tanh"]


def sigmoid(x: np.ndarray | float) -> np.ndarray:
    """The logistic function, written through tanh so that no input overflows.

    Args:
        x: Input value(s).

    Returns:
        ``1 / (1 + exp(-x))`` element-wise, in [0, 1], as float64.
    """
    return 0.5 * (1.0 + np.tanh(0.5 * np.asarray(x, dtype=np.float64)))


def tanh(x: np.ndarray | float) -> np.ndarray:
    """The hyperbolic tangent.

    Args:
        x: Input value(s).

    Returns:
        ``tanh(x)`` element-wise, in [-1, 1], as float64.
    """
    return np.tanh(np.asarray(x, dtype=np.float64))


def sin_act(x: np.ndarray | float) -> np.ndarray:
    """Sine: repeating patterns (symmetry along an input)."""
    return np.sin(np.asarray(x, dtype=np.float64))


def gaussian(x: np.ndarray | float) -> np.ndarray:
    """An unnormalised Gaussian bump: 1 at 0, falling off symmetrically.

    Args:
        x: Input value(s).

    Returns:
        ``exp(-x**2)`` element-wise, in [0, 1], as float64.
    """
    return np.exp(-np.square(np.asarray(x, dtype=np.float64)))


def relu(x: np.ndarray | float) -> np.ndarray:
    """The rectified linear unit.

    Args:
        x: Input value(s).

    Returns:
        ``max(0, x)`` element-wise, as float64.
    """
    return np.maximum(0.0, np.asarray(x, dtype=np.float64))


ACTIVATION_FUNCTIONS: dict[str, Callable[[np.ndarray | float], np.ndarray]] = {
    "sigmoid": sigmoid,
    "tanh": tanh,
    "sin": sin_act,
    "gaussian": gaussian,
    "relu": relu,
}

DEFAULT_ACTIVATION = "sigmoid"
