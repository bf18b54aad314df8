"""The plugin checkers' old home, kept so existing imports work: they live in
`ariel.evaluation` (``ariel.evaluation._checks``), the layer of the engine they run."""

from ariel.evaluation._checks import (
    check_all,
    check_body_encoder,
    check_controller,
    check_fitness,
    check_world,
)

__all__ = ["check_all", "check_body_encoder", "check_controller", "check_fitness", "check_world"]
