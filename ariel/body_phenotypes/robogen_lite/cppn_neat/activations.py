"""Activation functions of CPPN nodes, by name (upstream's set; numpy, element-wise)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["ACTIVATION_FUNCTIONS", "DEFAULT_ACTIVATION", "gaussian", "relu", "sigmoid", "tanh"]


def sigmoid(x: np.ndarray | float) -> np.ndarray:
    """The logistic function, written through tanh so that no input overflows."""
    return 0.5 * (1.0 + np.tanh(0.5 * np.asarray(x, dtype=np.float64)))


def tanh(x: np.ndarray | float) -> np.ndarray:
    return np.tanh(np.asarray(x, dtype=np.float64))


def sin_act(x: np.ndarray | float) -> np.ndarray:
    """Sine: repeating patterns (symmetry along an input)."""
    return np.sin(np.asarray(x, dtype=np.float64))


def gaussian(x: np.ndarray | float) -> np.ndarray:
    return np.exp(-np.square(np.asarray(x, dtype=np.float64)))


def relu(x: np.ndarray | float) -> np.ndarray:
    return np.maximum(0.0, np.asarray(x, dtype=np.float64))


ACTIVATION_FUNCTIONS: dict[str, Callable[[np.ndarray | float], np.ndarray]] = {
    "sigmoid": sigmoid,
    "tanh": tanh,
    "sin": sin_act,
    "gaussian": gaussian,
    "relu": relu,
}

DEFAULT_ACTIVATION = "sigmoid"
