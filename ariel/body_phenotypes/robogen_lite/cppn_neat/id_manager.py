"""`IdManager`: hands out node and innovation ids for a NEAT run, optionally kept in a file."""

from __future__ import annotations

import json
from pathlib import Path

__all__ = ["IdManager"]


class IdManager:
    """Counters of the last node id and the last innovation id used.

    With both ``node_start`` and ``innov_start`` given, it starts from them in memory (the file
    is only written by `save`). Otherwise it reads ``save_path`` if that file exists (upstream's
    persistent mode) and starts from 0 if not. Nothing is printed.

    Args:
        save_path: JSON file the counters are read from (unless both starts are given) and
            written to by `save`.
        node_start: Last node id used; the next one handed out is ``node_start + 1``. Used
            only together with ``innov_start``.
        innov_start: Last innovation id used; the next one handed out is
            ``innov_start + 1``. Used only together with ``node_start``.

    Raises:
        ValueError: If the counters are read from ``save_path`` and it is not a valid state
            file.
    """

    def __init__(
        self,
        save_path: str | Path = "id_state.json",
        node_start: int | None = None,
        innov_start: int | None = None,
    ) -> None:
        self.save_path = Path(save_path)
        if node_start is not None and innov_start is not None:
            self._node_id = int(node_start)
            self._innov_id = int(innov_start)
        else:
            self._node_id = 0
            self._innov_id = 0
            self.load()

    @property
    def node_id(self) -> int:
        """The last node id handed out."""
        return self._node_id

    @property
    def innov_id(self) -> int:
        """The last innovation id handed out."""
        return self._innov_id

    def get_next_node_id(self) -> int:
        self._node_id += 1
        return self._node_id

    def get_next_innov_id(self) -> int:
        self._innov_id += 1
        return self._innov_id

    def set_initial_ids(self, num_inputs: int, num_outputs: int) -> None:
        """Continue after a fresh genome's ids: nodes ``0 .. in+out-1``, innovations
        ``0 .. in*out-1`` (as ``Genome.random(..., next_innov_id=0)`` numbers them)."""
        self._node_id = int(num_inputs) + int(num_outputs) - 1
        self._innov_id = int(num_inputs) * int(num_outputs) - 1

    def save(self) -> None:
        """Write both counters to ``save_path`` as JSON."""
        state = {"next_node_id": self._node_id, "next_innov_id": self._innov_id}
        self.save_path.write_text(json.dumps(state, indent=4), encoding="utf-8")

    def load(self) -> None:
        """Read the counters from ``save_path`` if it exists; ``ValueError`` if it is not valid."""
        if not self.save_path.exists():
            return
        try:
            state = json.loads(self.save_path.read_text(encoding="utf-8"))
            self._node_id = int(state.get("next_node_id", 0))
            self._innov_id = int(state.get("next_innov_id", 0))
        except (OSError, ValueError, TypeError, AttributeError) as exc:
            raise ValueError(f"{self.save_path}: not an IdManager state file ({exc})") from None
