"""Pure-numpy forward pass of the Neural Developmental Encoding (no torch needed).

`NeuralDevelopmentalEncoding.to_numpy_weights()` exports the weights once; `nde_forward_numpy`
then maps genotypes to the same probability matrices as the torch module (float32, within
~1e-7) without torch's per-call overhead. This module imports only numpy, so evaluation
workers can decode bodies without loading torch.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = [
    "NUM_OF_CHROMOSOMES",
    "WEIGHT_NAMES",
    "nde_forward_numpy",
    "validate_genotype",
]

NUM_OF_CHROMOSOMES = 3
"""A genotype has three chromosomes: module types, connections, rotations."""

# Same keys as the torch module's state_dict, in creation order.
WEIGHT_NAMES: tuple[str, ...] = tuple(
    f"{layer}.{kind}"
    for layer in ("fc1", "fc2", "fc3", "fc4", "type_p_out", "conn_p_out", "rot_p_out")
    for kind in ("weight", "bias")
)

# Output width per head (types, faces, rotations); kept literal so this module needs no other
# ariel import. They equal NUM_OF_TYPES_OF_MODULES, NUM_OF_FACES and NUM_OF_ROTATIONS.
_TYPES, _FACES, _ROTATIONS = 4, 6, 3


def _to_numpy(value: Any) -> Any:
    """Turn a torch tensor into a numpy array (duck-typed, so torch is never imported)."""
    if hasattr(value, "detach") and hasattr(value, "cpu"):
        return value.detach().cpu().numpy()
    return value


def validate_genotype(genotype: Any, genotype_size: int) -> np.ndarray:
    """Check a genotype and return it as a float32 array of shape (3, genotype_size).

    Args:
        genotype: a list/tuple of three 1-D arrays, lists or tensors, or a (3, G) array or
            tensor, with finite numeric values.
        genotype_size: G, the required length of each chromosome.

    Returns:
        A new float32 array of shape ``(3, genotype_size)``.

    Raises:
        ValueError: a one-line message naming what is wrong: not three chromosomes, a
            chromosome of the wrong length or not numeric, or a NaN / inf value (including one
            beyond the float32 range).
    """
    genotype = _to_numpy(genotype)
    if isinstance(genotype, np.ndarray):
        if genotype.ndim != 2:
            msg = (
                f"genotype array must have shape ({NUM_OF_CHROMOSOMES}, {genotype_size}); "
                f"got shape {genotype.shape}"
            )
            raise ValueError(msg)
        chromosomes = list(genotype)
    elif isinstance(genotype, (str, bytes)) or not hasattr(genotype, "__len__"):
        msg = (
            f"genotype must be a sequence of {NUM_OF_CHROMOSOMES} chromosomes "
            f"(type, connection, rotation); got {type(genotype).__name__}"
        )
        raise ValueError(msg)
    else:
        chromosomes = list(genotype)
    if len(chromosomes) != NUM_OF_CHROMOSOMES:
        msg = (
            f"genotype must have exactly {NUM_OF_CHROMOSOMES} chromosomes "
            f"(type, connection, rotation); got {len(chromosomes)}"
        )
        raise ValueError(msg)

    out = np.empty((NUM_OF_CHROMOSOMES, genotype_size), dtype=np.float32)
    for k, chromosome in enumerate(chromosomes):
        try:
            arr = np.asarray(_to_numpy(chromosome))
        except (ValueError, TypeError) as exc:
            msg = f"chromosome {k} is not a numeric array: {exc}"
            raise ValueError(msg) from None
        if arr.dtype.kind not in "biuf":
            msg = f"chromosome {k} must be numeric; got dtype {arr.dtype}"
            raise ValueError(msg)
        if arr.shape != (genotype_size,):
            msg = (
                f"chromosome {k} must be a 1-D array of length {genotype_size}; "
                f"got shape {arr.shape}"
            )
            raise ValueError(msg)
        with np.errstate(over="ignore", invalid="ignore"):
            out[k] = arr  # values beyond float32 range become inf, caught just below
        if not np.all(np.isfinite(out[k])):
            msg = f"chromosome {k} contains NaN or inf values (or values beyond float32 range)"
            raise ValueError(msg)
    return out


def _sigmoid(x: np.ndarray) -> np.ndarray:
    """Numerically stable logistic function (no overflow warnings for large |x|)."""
    e = np.exp(-np.abs(x))
    return np.where(x >= 0, 1.0 / (1.0 + e), e / (1.0 + e)).astype(np.float32, copy=False)


def nde_forward_numpy(weights: Mapping[str, np.ndarray], genotype: Any) -> list[np.ndarray]:
    """Map a genotype to the (N, 4), (N, N, 6), (N, 3) float32 probability matrices.

    N and the genotype size G are read from the shapes of ``weights``.

    Args:
        weights: the dict returned by `NeuralDevelopmentalEncoding.to_numpy_weights()` (the
            state_dict as float32 arrays, Linear weights shaped (out, in)).
        genotype: three chromosomes of length G, in any form `validate_genotype` accepts.

    Returns:
        ``[types, connections, rotations]``: float32 arrays of shapes (N, 4), (N, N, 6) and
            (N, 3), with values in (0, 1) (independent sigmoids, not normalised).

    Raises:
        ValueError: ``weights`` lacks one of the expected keys, or ``genotype`` is invalid.

    Example:
        ```python
        import numpy as np

        from ariel.ec.genotypes.nde import NeuralDevelopmentalEncoding
        from ariel.ec.genotypes.nde.numpy_forward import nde_forward_numpy

        weights = NeuralDevelopmentalEncoding(20, 64, seed=0).to_numpy_weights()
        genotype = np.random.default_rng(1).random((3, 64))
        types, connections, rotations = nde_forward_numpy(weights, genotype)
        print(types.shape, connections.shape, rotations.shape)  # (20, 4) (20, 20, 6) (20, 3)
        ```
    """
    missing = [name for name in WEIGHT_NAMES if name not in weights]
    if missing:
        msg = f"NDE weights are missing {missing}; expected keys {list(WEIGHT_NAMES)}"
        raise ValueError(msg)
    w = {name: np.asarray(weights[name], dtype=np.float32) for name in WEIGHT_NAMES}
    genotype_size = w["fc1.weight"].shape[1]
    n = w["type_p_out.weight"].shape[0] // _TYPES

    x = validate_genotype(genotype, genotype_size)
    # Shared trunk, run on all three chromosomes at once.
    h = np.maximum(x @ w["fc1.weight"].T + w["fc1.bias"], 0.0)
    h = np.tanh(h @ w["fc2.weight"].T + w["fc2.bias"])
    h = np.maximum(h @ w["fc3.weight"].T + w["fc3.bias"], 0.0)
    h = np.maximum(h @ w["fc4.weight"].T + w["fc4.bias"], 0.0)

    heads = (
        ("type_p_out", (n, _TYPES)),
        ("conn_p_out", (n, n, _FACES)),
        ("rot_p_out", (n, _ROTATIONS)),
    )
    outputs = []
    for k, (name, shape) in enumerate(heads):
        z = h[k] @ w[f"{name}.weight"].T + w[f"{name}.bias"]
        outputs.append(_sigmoid(z).reshape(shape))
    return outputs
