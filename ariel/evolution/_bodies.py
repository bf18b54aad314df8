"""Bodies in the driver: genotype -> decoded, compiled body; its brain run; its evaluation tasks.

The driver compiles every new body once (for its parameter count, joints, descriptors and
graph, and to record its evaluations) and keeps the compiled models of living bodies only (a
run of days would otherwise keep every body it ever made). Workers get each body as its
decoded robot graph (`shipped_body`), so they never need the encoder.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import networkx as nx
import numpy as np

from ariel.body_phenotypes.robogen_lite.graph_io import graph_key, graph_to_plain
from ariel.evolution._brain import BrainRun
from ariel.evolution._seeds import derive_rng, derive_seed
from ariel.evolution._state import Body
from ariel.evolution._tasks import body_spec, evaluation_task, record_steps, shipped_body

if TYPE_CHECKING:
    import mujoco

    from ariel.evaluation import BodySpec, EvaluationTask
    from ariel.evolution._config import ExperimentConfig
    from ariel.plugins import BodyEncoder, ControllerPlugin

__all__ = ["BodyFactory", "BrainJob"]


@dataclass
class BrainJob:
    """One body's brain run in one generation: learn until ``run.iteration == target``."""

    body: Body
    spec: BodySpec  # as shipped to the workers (`shipped_body`)
    run: BrainRun
    target: int
    eval_seed: int
    record_every: int


def graph_text(decoded: nx.DiGraph) -> str:
    """The bodies table's ``graph`` of an encoder's decoded graph: node-link JSON, or ``""``
    (stored as a body without a graph) for one no `graph_key` is made of, an empty graph: a
    decode that changed between calls stopped the run, and readers called the table damaged."""
    graph = graph_to_plain(decoded)
    text = json.dumps(nx.node_link_data(graph, edges="edges"), sort_keys=True)
    try:
        graph_key(text)
    except Exception:  # the encoder's output: anything
        return ""
    return text


class BodyFactory:
    """Makes and compiles bodies, their brain runs and their evaluation tasks for one run."""

    def __init__(
        self,
        config: ExperimentConfig,
        encoder: BodyEncoder,
        controller: ControllerPlugin,
        maximise: bool,
    ) -> None:
        self.config = config
        self.encoder = encoder
        self.controller = controller
        self.maximise = maximise
        # body number -> compiled model (this process only)
        self._models: dict[int, mujoco.MjModel] = {}

    def task(
        self, spec: BodySpec, params: np.ndarray | tuple[float, ...] = (), **fields: object
    ) -> EvaluationTask:
        # One place builds a run's tasks (`_tasks.evaluation_task`): replay rebuilds the same.
        return evaluation_task(self.config, spec, params, **fields)

    def new_body(self, number: int, genotype: object, parents: list[str], generation: int) -> Body:
        """Decode and compile a body here (its parameter count, joints, descriptors, graph)."""
        # `ariel watch` imports this module (ariel.recording.viewer: `budget`, via _driver)
        # lazy: the engine imports mujoco and with it the GL backend (ariel.utils._gl)
        from ariel.evaluation import BodyBuildError, build

        spec = body_spec(self.config, genotype)
        body = Body(number=number, genotype=spec.genotype, parent_ids=parents, born=generation)
        try:
            built = build(self.task(spec))
        except BodyBuildError as exc:
            body.status, body.error = "error", str(exc).splitlines()[0]
            return body
        body.n_params = int(self.controller.num_parameters(built.model))
        body.n_joints = int(built.model.nu)
        body.joint_names = list(built.joint_names)
        body.descriptors = dict(built.descriptors)
        with contextlib.suppress(Exception):  # a body without a graph form (some prebuilts)
            body.graph = graph_text(self.encoder.decode(spec.genotype))
        self._models[number] = built.model
        return body

    def model(self, body: Body) -> mujoco.MjModel:
        """The body's compiled model (compiled again for a body restored from a checkpoint)."""
        if body.number not in self._models:
            self.new_body(body.number, body.genotype, body.parent_ids, body.born)
        return self._models[body.number]

    def forget_models(self, alive: Sequence[Body]) -> None:
        """Drop the compiled models of bodies not in ``alive`` (each holds ~0.3 MB)."""
        keep = {body.number for body in alive}
        for number in [n for n in self._models if n not in keep]:
            del self._models[number]

    def new_brain(self, body: Body, population: Mapping[str, Body]) -> BrainRun:
        """Body ``body``'s brain run (its learner: ``brain.optimizer``): x0 random, or its
        first parent's best brain when ``brain.inherit`` and the parameter counts agree."""
        c, seed = self.config, self.config.seed
        if body.n_params == 0:
            x0 = np.zeros(0)
        else:
            rng = derive_rng(seed, "brain-x0", body.number)
            x0 = self.controller.random_parameters(self.model(body), rng, 1)[0]
            parent = population.get(body.parent_ids[0]) if body.parent_ids else None
            if (
                c.brain.inherit
                and parent is not None
                and parent.best_params is not None
                and len(parent.best_params) == body.n_params
            ):
                x0 = np.asarray(parent.best_params, dtype=np.float64)
        return BrainRun(
            n_params=body.n_params,
            popsize=c.brain.popsize,
            maximise=self.maximise,
            x0=x0,
            sigma0=c.brain.sigma0,
            seed=derive_seed(seed, "cma", body.number),  # "cma": the key of the first learner
            optimizer=c.brain.optimizer,
            options=dict(c.brain.optimizer_options),
        )

    def job(self, body: Body, run: BrainRun, target: int) -> BrainJob:
        """The brain job of ``body`` up to iteration ``target`` (1 for a body without
        parameters: its one evaluation)."""
        timestep = self.model(body).opt.timestep
        return BrainJob(
            body=body,
            spec=shipped_body(self.config, body_spec(self.config, body.genotype)),
            run=run,
            target=target if body.n_params else 1,
            eval_seed=derive_seed(self.config.seed, "evaluation", body.number),
            record_every=record_steps(self.config, timestep),
        )

    def batch_tasks(
        self, job: BrainJob, params: np.ndarray, record_bodies: bool
    ) -> list[EvaluationTask]:
        """The tasks of the job's next batch (candidate k of iteration i: ``-iIII-cKKK``)."""
        iteration = job.run.iteration
        return [
            self.task(
                job.spec,
                p,
                seed=job.eval_seed,
                record_every=job.record_every,
                record_bodies=record_bodies,
                eval_id=f"{job.body.body_id}-i{iteration:03d}-c{k:03d}",
            )
            for k, p in enumerate(params)
        ]
