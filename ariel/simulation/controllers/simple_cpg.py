"""`SimpleCPG`: coupled Hopf oscillators as a torch module (upstream's ``simple_cpg``).

Node ``i`` has state ``(x_i, y_i)``, ``r_i^2 = x_i^2 + y_i^2``, phase angle
``theta_i = atan2(y_i, x_i)`` and follows

    dx_i/dt = (mu - r_i^2) x_i - w_i y_i + ha_i * sum_j sin(theta_j - theta_i) (x_j - x_i)
    dy_i/dt = (mu - r_i^2) y_i + w_i x_i + ha_i * sum_j sin(theta_j - theta_i) (y_j - y_i)

over its neighbours ``j``; the joint target is ``clip(amplitudes_i * y_i + phase_i + b_i)``.
Same parameter API as `NaCPG` (groups phase, w, amplitudes, ha, b; ``5 n`` parameters).
As our `NaCPG` (docs/decisions.md), ``forward(time)`` integrates to ``time`` in Euler steps of
``dt`` (upstream takes one step per call whatever the time); ``time=None`` takes one step;
``time == 0`` or an earlier time restarts. ``seed`` seeds a private generator; without one
torch's global RNG is used.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from os import PathLike
from typing import Any

import numpy as np
import torch
from torch import nn

from ariel.simulation.controllers.na_cpg import create_fully_connected_adjacency, time_step

__all__ = ["SimpleCPG", "create_fully_connected_adjacency"]

E = 1e-9  # keeps atan2 and the radius defined at the origin, as upstream
_GROUPS = ("phase", "w", "amplitudes", "ha", "b")


def _coupling_matrix(adjacency: dict[int, list[int]]) -> np.ndarray:
    """The ``(n, n)`` 0/1 coupling matrix of ``adjacency`` (keys ``0 .. n-1``); `ValueError`
    for a neighbour that is unknown or the node itself."""
    n = len(adjacency)
    coupling = np.zeros((n, n))
    for i, neighbours in adjacency.items():
        for j in neighbours:
            if not 0 <= j < n or j == i:
                raise ValueError(f"node {i} has neighbour {j}; allowed: 0..{n - 1}, not itself")
            coupling[i, j] = 1.0
    return coupling


class SimpleCPG(nn.Module):
    """One Hopf oscillator per joint; ``forward(time)`` returns joint targets (radians).

    The parameters (``phase``, ``w``, ``amplitudes``, ``ha``, ``b``, each ``(n,)`` float64
    ``nn.Parameter``) and the initial ``x``, ``y`` are drawn at random; set the parameters
    with ``set_flat_params`` or ``set_params_by_group``.

    Args:
        adjacency_dict: ``{node: [neighbours]}`` with keys ``0 .. n-1``, one node per
            actuator, no node its own neighbour (e.g. ``create_fully_connected_adjacency(n)``).
        mu: Squared radius of the oscillators' limit cycle (the ``mu`` of the equations
            above).
        dt: Euler integration step, in seconds (finite, > 0).
        hard_bounds: ``(low, high)`` the joint targets are clipped to, in radians; None: no
            clip.
        angle_tracking: Append every output of ``forward`` to ``angle_history``.
        seed: Seed of a private torch generator for the initial draws; None: torch's global
            RNG.

    Raises:
        TypeError: If ``adjacency_dict`` is not a mapping.
        ValueError: If ``adjacency_dict`` has keys other than ``0 .. n-1`` or lists an
            unknown node or the node itself, or ``dt`` is out of range.
    """

    def __init__(
        self,
        adjacency_dict: Mapping[int, Sequence[int]],
        mu: float = 1.0,
        dt: float = 0.01,
        hard_bounds: tuple[float, float] | None = (-math.pi / 2, math.pi / 2),
        *,
        angle_tracking: bool = False,
        seed: int | None = None,
    ) -> None:
        super().__init__()
        if not isinstance(adjacency_dict, Mapping):
            raise TypeError(
                "adjacency_dict must be a dict {node: [neighbours]}, e.g. "
                f"create_fully_connected_adjacency(n); got {type(adjacency_dict).__name__}"
            )
        n = len(adjacency_dict)
        if sorted(adjacency_dict) != list(range(n)):
            raise ValueError(
                f"adjacency_dict keys must be 0..{n - 1}; got {sorted(adjacency_dict)}"
            )
        self.adjacency_dict = {int(k): [int(j) for j in v] for k, v in adjacency_dict.items()}
        self._coupling = _coupling_matrix(self.adjacency_dict)
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a finite number > 0; got {dt}")
        self.n, self.mu, self.dt = n, float(mu), float(dt)
        self.hard_bounds = (
            None if hard_bounds is None else (float(hard_bounds[0]), float(hard_bounds[1]))
        )
        self.angle_tracking = bool(angle_tracking)
        self.clamping_error = 0.0
        self.angle_history: list[list[float]] = []

        generator = None if seed is None else torch.Generator().manual_seed(int(seed))

        def rand(*shape: int) -> torch.Tensor:
            return torch.rand(*shape, generator=generator, dtype=torch.float64)

        def randn(*shape: int) -> torch.Tensor:
            return torch.randn(*shape, generator=generator, dtype=torch.float64)

        def param(values: torch.Tensor) -> nn.Parameter:
            return nn.Parameter(values, requires_grad=False)

        self.phase = param((rand(n) * 2 - 1) * math.pi)
        self.w = param((rand(n) * 2 - 1) * 4.0 + 2.0)
        self.amplitudes = param((rand(n) * 2 - 1) * 2.0 + 1.0)
        self.ha = param(randn(n) * 0.5)
        self.b = param(randn(n) * 0.1)
        self.parameter_groups = {name: getattr(self, name) for name in _GROUPS}
        self.num_of_parameters = len(_GROUPS) * n
        self.num_of_parameter_groups = len(_GROUPS)
        self.register_buffer("x", randn(n) * 0.1)
        self.register_buffer("y", randn(n) * 0.1)
        self.register_buffer("angles", torch.zeros(n, dtype=torch.float64))
        self.initial_state = {k: getattr(self, k).clone() for k in ("x", "y", "angles")}
        self._steps = 0

    # ---- parameters ------------------------------------------------------------------------

    def param_type_converter(self, params: Any) -> torch.Tensor:
        """A list, numpy array or tensor as a float64 tensor."""
        if isinstance(params, torch.Tensor):
            return params.detach().to(dtype=torch.float64)
        return torch.as_tensor(np.asarray(params, dtype=np.float64))

    def set_flat_params(self, params: Any) -> None:
        values = self.param_type_converter(params).reshape(-1)
        if values.numel() != self.num_of_parameters:
            raise ValueError(
                f"Parameter vector has incorrect size. Expected {self.num_of_parameters}, "
                f"got {values.numel()}."
            )
        for k, group in enumerate(self.parameter_groups.values()):
            group.data = values[k * self.n : (k + 1) * self.n].clone()
        self.reset()

    def set_params_by_group(self, group_name: str, params: Any) -> None:
        if group_name not in self.parameter_groups:
            raise ValueError(
                f"Parameter group {group_name!r} does not exist; groups: {', '.join(_GROUPS)}"
            )
        values = self.param_type_converter(params).reshape(-1)
        if values.numel() != self.n:
            raise ValueError(f"group {group_name!r} has {self.n} values; got {values.numel()}")
        self.parameter_groups[group_name].data = values.clone()
        self.reset()

    def set_param_with_dict(self, params: Mapping[str, Any]) -> None:
        for key, value in params.items():
            self.set_params_by_group(key, value)

    def get_flat_params(self) -> torch.Tensor:
        return torch.cat([p.detach().flatten() for p in self.parameter_groups.values()])

    # ---- dynamics --------------------------------------------------------------------------

    def reset(self) -> None:
        """Restore the oscillators' initial state."""
        for key, value in self.initial_state.items():
            setattr(self, key, value.clone())
        self.angle_history = []
        self._steps = 0

    def _step(self) -> None:
        x, y = self.x.numpy(), self.y.numpy()
        w, ha = self.w.detach().numpy(), self.ha.detach().numpy()
        r2 = x * x + y * y + E
        theta = np.arctan2(y, x + E)
        pull = ha[:, None] * np.sin(theta[None, :] - theta[:, None]) * self._coupling
        dx = (self.mu - r2) * x - w * y + (pull * (x[None, :] - x[:, None])).sum(axis=1)
        dy = (self.mu - r2) * y + w * x + (pull * (y[None, :] - y[:, None])).sum(axis=1)
        self.x = torch.from_numpy(x + dx * self.dt)
        self.y = torch.from_numpy(y + dy * self.dt)
        self._steps += 1

    def forward(self, time: float | None = None) -> torch.Tensor:
        """Joint targets at simulated ``time`` (float32, shape ``(n,)``)."""
        if time is None:
            self._step()
        else:
            target, restart = time_step("SimpleCPG", time, self.dt, self._steps)
            if restart:
                self.reset()
            while self._steps < target:
                self._step()
        angles = self.amplitudes.detach() * self.y + self.phase.detach() + self.b.detach()
        if self.hard_bounds is not None:
            clamped = angles.clamp(*self.hard_bounds)
            self.clamping_error = float((angles - clamped).abs().sum())
            angles = clamped
        if torch.isnan(angles).any():
            raise ValueError("SimpleCPG produced NaN angles; check the parameters (w, ha, mu)")
        if self.angle_tracking:
            self.angle_history.append(angles.tolist())
        self.angles = angles
        return angles.to(torch.float32)

    # ---- files -----------------------------------------------------------------------------

    def save(self, path: str | PathLike[str]) -> None:
        torch.save({k: p.detach().cpu() for k, p in self.parameter_groups.items()}, path)

    def load(self, path: str | PathLike[str]) -> None:
        loaded = torch.load(path, map_location="cpu", weights_only=True)
        self.set_param_with_dict({k: loaded[k] for k in _GROUPS})
