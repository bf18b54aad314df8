"""Different bodies in one model (`ariel.evaluation._warp_pack`): each packed robot moves as it
does alone, touches the world as alone and never touches another robot.

On the CPU (float64) MuJoCo solves each robot's contacts as an island of its own, so packed and
lone trajectories agree to rounding (about 3e-15 after 0.3 s; the tolerance is 1e-9). On MuJoCo
Warp (float32) all robots of a world share one Newton solve; they agree to float32 rounding
(about 1e-6 after 0.3 s, as MuJoCo Warp agrees with the CPU; tolerance 1e-5).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from _helpers import count_warp_module_loads

from ariel._builtin_names import BUILTIN_PLUGINS
from ariel.evaluation import BodySpec, EvaluationTask, build, evaluate_batch
from ariel.evaluation._engine import (
    _finish,
    control_sequence,
    frame_steps,
    num_steps,
    open_loop_targets,
)
from ariel.evaluation._warp_pack import (
    MAX_ROBOTS,
    PAD_PREFIX,
    PackedModel,
    nv_bucket,
    pack,
    pack_groups,
    packable,
)
from ariel.plugins import controllers, fitness_functions, worlds
from ariel.simulation.environments import SimpleFlatWorld

OPTIONS = {"number_of_modules": 12}


@pytest.fixture(scope="module")
def tasks() -> list[EvaluationTask]:
    """33 random NDE bodies (the default encoder) of several sizes."""
    from ariel.plugins import body_encoders

    encoder = body_encoders.make("nde", **OPTIONS)
    rng = np.random.default_rng(11)
    bodies = [BodySpec("nde", encoder.random_genotype(rng), OPTIONS) for _ in range(33)]
    return [EvaluationTask(body=b, duration=0.3, eval_id=f"b{i}") for i, b in enumerate(bodies)]


@pytest.fixture(scope="module")
def builts(tasks):
    return [build(t) for t in tasks]


def _step(model: mujoco.MjModel, state: np.ndarray, controls: np.ndarray) -> tuple:
    """qpos after each step ``(T, nq)`` and the contacts' geom pairs ``(N, 2)`` of all steps."""
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    qpos = np.empty((len(controls), model.nq))
    pairs = []
    for t, ctrl in enumerate(controls):
        data.ctrl[:] = ctrl
        mujoco.mj_step(model, data)
        qpos[t] = data.qpos
        pairs.append(data.contact.geom[: data.ncon].copy())
    return qpos, np.concatenate(pairs)


def _owners(packed: PackedModel) -> np.ndarray:
    """Each packed geom's robot, -1 for the world's."""
    owner = np.full(packed.model.ngeom, -1)
    for k, robot in enumerate(packed.robots):
        owner[np.isin(packed.model.geom_bodyid, robot.robot_bodies)] = k
    return owner


def _check_as_alone(packed: PackedModel, duration: float) -> float:
    """Step ``packed`` with random controls per robot and each robot alone with the same ones;
    returns the largest qpos difference (and checks the contacts and the padding)."""
    model = packed.model
    nstep = round(duration / model.opt.timestep)
    rng = np.random.default_rng(len(packed.robots))
    controls = [rng.uniform(-1.5, 1.5, (nstep, r.built.model.nu)) for r in packed.robots]
    qpos, pairs = _step(model, packed.initial_state, packed.packed_ctrl(controls))
    owner = _owners(packed)[pairs]
    assert np.all((owner[:, 0] == owner[:, 1]) | (owner.min(axis=1) == -1)), "robots touched"
    assert np.any(owner.min(axis=1) == -1), "no robot touched the floor"
    if packed.padding:
        assert np.all(qpos[:, -packed.padding :] == 0.0)  # the inert dofs stay where they are
    worst = 0.0
    for k, robot in enumerate(packed.robots):
        lone = robot.built
        np.testing.assert_array_equal(
            packed.robot_qpos(packed.initial_state[1 : 1 + model.nq], k), lone.model.qpos0
        )
        alone, _ = _step(lone.model, lone.initial_state, controls[k])
        assert np.abs(alone[-1] - alone[0]).max() > 1e-3  # it moved
        worst = max(worst, float(np.abs(packed.robot_qpos(qpos, k) - alone).max()))
    return worst


@pytest.mark.parametrize(
    ("count", "duration", "settle"), [(1, 0.3, 0.0), (2, 0.3, 0.0), (8, 0.3, 0.2), (32, 0.1, 0.0)]
)
def test_packed_robots_move_as_they_do_alone(tasks, builts, count, duration, settle) -> None:
    if settle:  # settled bodies start from their settled lone poses
        chosen = [EvaluationTask(body=t.body, settle=settle) for t in tasks[:count]]
        packed = pack(chosen)
    else:
        packed = pack(tasks[:count], builts[:count])
    assert count == 1 or len({r.built.model.nv for r in packed.robots}) > 1  # different sizes
    assert packed.model.nv == nv_bucket(sum(r.built.model.nv for r in packed.robots))
    worst = _check_as_alone(packed, duration)
    print(f"{count} robots, {duration} s: qpos at most {worst:.1e} from alone")
    assert worst < 1e-9


def test_robots_keep_their_lone_ids_layout_and_names(tasks, builts) -> None:
    packed = pack(tasks[:3], builts[:3])
    model = packed.model
    for k, robot in enumerate(packed.robots):
        assert robot.prefix == f"robot{k + 1}_"
        assert model.geom(robot.core_geom).name == f"robot{k + 1}_core"
        names = [model.body(int(b)).name for b in robot.robot_bodies]
        assert names == [n.replace("robot1_", robot.prefix, 1) for n in robot.built.body_names]
        joints = model.actuator_trnid[robot.ctrl, 0]
        np.testing.assert_array_equal(model.jnt_qposadr[joints], robot.joint_qpos)
    assert model.body(f"{PAD_PREFIX}0").id > packed.robots[-1].robot_bodies.max()


def test_packed_frames_give_the_engine_s_results(tasks, builts) -> None:
    """The CPU engine's own `_finish` turns a robot's packed frames into its lone result."""
    controller, fitness = controllers.make("na_cpg"), fitness_functions.get("xy_displacement")
    rng = np.random.default_rng(2)
    chosen = [
        EvaluationTask(
            body=t.body,
            params=controller.random_parameters(b.model, rng, 1)[0],
            duration=0.3,
            settle=0.1,
            record_every=25,
            seed=5,
        )
        for t, b in zip(tasks[:2], builts[:2])
    ]
    packed = pack(chosen)
    head, model = chosen[0], packed.model
    nstep, dt, period = num_steps(head, model), model.opt.timestep, head.control_period
    controls = []
    for task, robot in zip(chosen, packed.robots):
        lone = robot.built
        times = np.arange(0, nstep, period) * dt
        targets = open_loop_targets(controller, np.array([task.params]), [5], times, lone.model)
        controls.append(control_sequence(targets, nstep, period, 0.5, lone.low, lone.high)[0])
    qpos, _ = _step(model, packed.initial_state, packed.packed_ctrl(controls))
    steps = frame_steps(nstep, head.record_every)
    frames = np.vstack([packed.initial_state[None, 1 : 1 + model.nq], qpos])[steps]
    for k, (task, lone) in enumerate(zip(chosen, evaluate_batch(chosen))):
        robot = packed.robots[k]
        target = controls[k][np.minimum(steps, nstep - 1)]
        result = _finish(
            task, robot.built, fitness, steps * dt, packed.robot_qpos(frames, k), target, True, 0.0
        )
        assert result.status == lone.status == "ok"
        assert math.isclose(result.fitness, lone.fitness, rel_tol=0, abs_tol=1e-9)
        np.testing.assert_allclose(result.core_pos, lone.core_pos, rtol=0, atol=1e-9)
        np.testing.assert_allclose(result.joint_angle, lone.joint_angle, rtol=0, atol=1e-9)


class _BallWorld(SimpleFlatWorld):
    """A flat world with a ball every packed robot would share."""

    def _build(self) -> None:
        super()._build()
        ball = self.spec.worldbody.add_body(name="ball", pos=[1.0, 0.0, 0.1])
        ball.add_freejoint()
        ball.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.05, 0, 0])


class _BitsWorld(SimpleFlatWorld):
    """A flat world whose floor collides by bit 1 (contype 2)."""

    def _build(self) -> None:
        super()._build()
        self.spec.geoms[0].contype = 2


def test_static_worlds_pack_and_others_say_why_not(tasks, builts) -> None:
    body = tasks[0].body
    for name in BUILTIN_PLUGINS["world"]:  # all built-in worlds are static floors or terrains
        assert packable(EvaluationTask(body=body, world=name)) is None, name
    worlds.register("test_pack_ball", _BallWorld)
    worlds.register("test_pack_bits", _BitsWorld)
    try:
        ball = EvaluationTask(body=body, world="test_pack_ball")
        assert "joints (movable objects" in packable(ball)
        assert "bit 0" in packable(EvaluationTask(body=body, world="test_pack_bits"))
        with pytest.raises(ValueError, match="cannot be packed: world 'test_pack_ball'"):
            pack([ball])
    finally:
        worlds.unregister("test_pack_ball")
        worlds.unregister("test_pack_bits")
    rugged = [EvaluationTask(body=t.body, world="rugged") for t in tasks[:2]]
    assert _check_as_alone(pack(rugged), 0.1) < 1e-9  # a heightfield, robots lifted as alone
    with pytest.raises(ValueError, match="share one world"):
        pack([tasks[0], rugged[1]])


def test_more_robots_than_bits_go_in_several_models(tasks, builts) -> None:
    with pytest.raises(ValueError, match=f"1 to {MAX_ROBOTS} tasks, not 33"):
        pack(tasks, builts)
    groups = pack_groups(tasks, builts)
    assert [len(g.robots) for g in groups] == [16, 17]
    assert [r.built for g in groups for r in g.robots] == builts


def test_nv_buckets() -> None:
    sizes = np.arange(1, 1100)
    buckets = np.array([nv_bucket(int(n)) for n in sizes])
    assert np.all(buckets >= sizes) and np.all(np.diff(buckets) >= 0)
    assert np.all((buckets - sizes <= np.maximum(16, sizes / 8))[sizes > 32])
    assert len(set(buckets[(sizes > 256) & (sizes <= 512)])) == 8
    assert nv_bucket(32) == 32 and nv_bucket(33) == 48 and nv_bucket(300) == 320


# --------------------------------------------------------------------------------------------
# MuJoCo Warp (Warp's CPU device)
# --------------------------------------------------------------------------------------------


def _warp_qpos(packed: PackedModel, controls: np.ndarray, every: int = 25) -> np.ndarray:
    """``packed`` on MuJoCo Warp, world ``w`` with ``controls[w]`` ``(T, nu)``; qpos frames."""
    from ariel.evaluation._warp import warp_modules

    wp, mjw = warp_modules()
    model = packed.model
    with wp.ScopedDevice("cpu"):
        m = mjw.put_model(model)
        start = mujoco.MjData(model)
        mujoco.mj_setState(model, start, packed.initial_state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        d = mjw.put_data(model, start, nworld=controls.shape[0], nconmax=64, njmax=256)
        frames = []
        for t in range(controls.shape[1]):
            d.ctrl.assign(controls[:, t].astype(np.float32))
            mjw.step(m, d)
            if (t + 1) % every == 0:
                frames.append(d.qpos.numpy().astype(np.float64))
    return np.stack(frames, axis=1)


@pytest.mark.warp
def test_packed_worlds_on_mujoco_warp_match_lone_ones_and_compile_nothing_new(
    tasks, builts, monkeypatch
) -> None:
    """Two bodies in one model on MuJoCo Warp, two brains each (world w: brain w of both),
    against each body packed alone: the same nv bucket, so the lone runs compile nothing."""
    pytest.importorskip("mujoco_warp", reason="MuJoCo Warp not installed: make gpu")

    packed = pack(tasks[:2], builts[:2])
    alone = [pack([t], [b]) for t, b in zip(tasks[:2], builts[:2])]
    assert {p.model.nv for p in alone} == {packed.model.nv} == {32}
    rng = np.random.default_rng(4)
    controls = [rng.uniform(-1.5, 1.5, (2, 100, b.model.nu)) for b in builts[:2]]
    qpos = _warp_qpos(packed, packed.packed_ctrl(controls))

    fresh = count_warp_module_loads(monkeypatch)
    for k, lone in enumerate(alone):
        lone_qpos = _warp_qpos(lone, controls[k])
        difference = np.abs(packed.robot_qpos(qpos, k) - lone.robot_qpos(lone_qpos, 0)).max()
        print(f"robot {k}: packed vs alone on MuJoCo Warp, at most {difference:.1e} apart")
        assert difference < 1e-5
    assert fresh, "no Warp module was asked for: the count below would be vacuous"
    assert sum(fresh) == 0, "a model in the same nv bucket loaded or compiled Warp modules"
