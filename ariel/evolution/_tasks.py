"""The evaluation task of a run: built here, by the loop and by replay alike.

Everything an evaluation depends on comes from the experiment config (plugins, their options,
duration, control, spawn, record rate) and three values of the evaluation itself (genotype,
controller parameters, seed), all stored in the run folder. Building the task in one place is
what lets `ariel.recording.replay` reproduce a stored fitness bit for bit.
"""

from __future__ import annotations

from typing import Any

import networkx as nx
import numpy as np

from ariel.body_phenotypes.robogen_lite.graph_io import graph_to_plain
from ariel.evaluation import BodySpec, EvaluationTask
from ariel.evolution._config import ExperimentConfig
from ariel.plugins import body_encoders

__all__ = ["body_spec", "evaluation_task", "record_bodies", "record_steps", "shipped_body"]


def body_spec(config: ExperimentConfig, genotype: object) -> BodySpec:
    """The `BodySpec` of ``genotype`` under the config's body encoder and options."""
    return BodySpec(config.body.encoder, genotype, config.body.options)


def shipped_body(config: ExperimentConfig, body: BodySpec) -> BodySpec:
    """The form of ``body`` (a `BodySpec`) that evaluation tasks carry to the workers.

    A body whose encoder decodes it to a robot graph travels as that graph (the ``graph``
    encoder's node-link data): the driver decodes each body once, and a worker needs only the
    constructor, never the encoder. For the NDE that keeps torch (~220 MiB resident, needed to
    make its weights) out of every worker. The compiled model is the same byte for byte, so
    fitness is too. A body that does not decode to a valid graph keeps its genotype (the worker
    then reports the error the driver saw), as does one whose encoder builds it directly
    (``prebuilt``).
    """
    if body.encoder == "graph":
        return body
    # `ariel view` imports this module (ariel.recording.resim._replay: has_body_poses)
    # lazy: the constructor imports mujoco and with it the GL backend (ariel.utils._gl)
    from ariel.body_phenotypes.robogen_lite.constructor import validate_robot_graph

    encoder = body_encoders.make(body.encoder, **body.options)
    if hasattr(encoder, "build"):
        return body
    try:
        graph = encoder.decode(body.genotype)
        validate_robot_graph(graph)
    except Exception:  # the worker's build raises it again, as `BodyBuildError`
        return body
    return BodySpec("graph", nx.node_link_data(graph_to_plain(graph), edges="edges"))


def record_steps(config: ExperimentConfig, timestep: float) -> int:
    """Physics steps between recorded frames for ``record.rate_hz`` on a model's timestep.

    The recorded frames are what the fitness function sees, so this is part of the experiment.
    """
    return max(1, round(1.0 / (config.record.rate_hz * timestep)))


def record_bodies(config: ExperimentConfig) -> bool:
    """Whether evaluations return every body's pose: for Rerun recordings that show them.

    Poses are computed from the recorded frames after the physics, so this never changes a
    fitness; it is part of the task only so that replay rebuilds the loop's task exactly.
    """
    record = config.record
    return bool(getattr(record, "rerun", False)) and getattr(record, "bodies", "none") != "none"


def evaluation_task(
    config: ExperimentConfig,
    body: BodySpec,
    params: np.ndarray | tuple[float, ...] = (),
    **fields: object,
) -> EvaluationTask:
    """The `EvaluationTask` of one evaluation of ``body`` (a `BodySpec`) in this experiment.

    ``fields`` sets the per-evaluation ones (``seed``, ``record_every``, ``eval_id``) and may
    override any other (replay asks for full-rate frames with ``record_every=1``).
    """
    c = config
    # Any: the keywords of `EvaluationTask`, each of its own type (``fields`` may set any).
    values: dict[str, Any] = {
        "body": body,
        "params": params,
        "controller": c.brain.controller,
        "controller_options": c.brain.options,
        "world": c.world.name,
        "world_options": c.world.options,
        "fitness": c.task.fitness,
        "fitness_options": c.task.options,
        "duration": c.task.duration,
        "settle": c.task.settle,
        "control_period": c.brain.control_period,
        "smoothing": c.brain.smoothing,
        "record_bodies": record_bodies(config),
        "spawn_position": c.task.spawn_position,
    }
    values.update(fields)
    return EvaluationTask(**values)
