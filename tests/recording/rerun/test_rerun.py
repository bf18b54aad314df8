"""Rerun recordings of a run: a readable .rrd per recorded evaluation (3D replay, joints,
graph, properties), a generation's evaluations.rrd, run.rrd, blueprint.rbl; record.bodies;
crash safety and resume."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

rr = pytest.importorskip("rerun")

from ariel.evolution import ConfigError, load_config, resume_experiment, run_experiment  # noqa: E402
from ariel.recording import load_run  # noqa: E402
from ariel.recording.rerun._joint_names import joint_labels  # noqa: E402

SMALL = {
    "name": "rrd",
    "seed": 3,
    "generations": 2,
    "body": {"options": {"number_of_modules": 6}, "population": 2, "offspring": 2},
    "brain": {"popsize": 3, "iterations": 2},
    "task": {"duration": 0.5},
    "record": {"rerun": True, "bodies": "all", "rate_hz": 10},
    "executor": {"kind": "serial"},
}
FRAMES = 6  # 10 Hz over 0.5 s, first frame at t = 0
#: A hinge's label in a morphology graph: its branch and number ("right 1").
HINGE = re.compile(r"(front|back|right|left) \d+")


def short(joint_label: str) -> str:
    """The graph's label of a joint's hinge: "right branch, hinge 1" -> "right 1"."""
    return re.sub(r"^(\w+) branch, hinge (\d+)$", r"\1 \2", joint_label)


def small(**record: Any) -> dict[str, Any]:
    config = json.loads(json.dumps(SMALL))
    config["record"].update(record)
    return config


def chunks(path: Path) -> dict[tuple[str, bool], Any]:
    """(entity, static) -> that chunk's Arrow record batch, read back from an .rrd."""
    store = rr.chunk.RrdReader(path).stream().collect()
    found = {}
    for chunk in store.stream().to_chunks():
        key = (chunk.entity_path, chunk.is_static)
        if key == ("/__properties", True):  # Rerun's own: start time, name
            continue
        assert key not in found, f"{path.name}: two chunks for {key}"
        found[key] = chunk.to_record_batch()
    return found


def column(batch: Any, name: str) -> list[Any]:
    return batch.column(name).to_pylist()


def recordings(run_dir: Path) -> dict[str, Path]:
    """Eval id -> its own recording (a generation's evaluations.rrd left out)."""
    found = sorted((run_dir / "recordings").glob("gen-*/*.rrd"))
    return {p.stem: p for p in found if p.name != "evaluations.rrd"}


def generation_recordings(run_dir: Path) -> list[Path]:
    return sorted((run_dir / "recordings").glob("gen-*/evaluations.rrd"))


def steps(path: Path) -> list[str]:
    """The eval ids of a generation recording's steps, in order (from their text cards)."""
    cards = column(chunks(path)[("/evaluation", False)], "TextDocument:text")
    return [card[0].splitlines()[0].removeprefix("## ") for card in cards]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("runs") / "recorded"
    result = run_experiment(small(), out=out)
    return result, load_run(out)


def test_every_evaluation_has_one_readable_recording_named_after_it(recorded) -> None:
    result, run = recorded
    ran = run.evaluations[run.evaluations["status"] != "error"]
    files = recordings(result.run_dir)
    assert len(files) == len(ran) > 0
    assert set(files) == set(ran["eval_id"])
    for _, row in ran.iterrows():
        path = files[row["eval_id"]]
        assert path.parent.name == f"gen-{row['generation']:06d}"
        (entry,) = rr.chunk.RrdReader(path).recordings()
        assert entry.application_id == "ariel" and entry.recording_id == row["eval_id"]
    assert not list(result.run_dir.rglob("*.tmp"))


def test_a_recording_replays_every_body_and_holds_the_joint_series_of_the_tables(
    recorded,
) -> None:
    result, run = recorded
    evals = run.evaluations[run.evaluations["status"] == "ok"]
    traj = run.trajectories
    for _, row in evals.iterrows():
        found = chunks(recordings(result.run_dir)[row["eval_id"]])
        # Geometry: one box per module geom (a hinge has two: stator and rotor), coloured
        # by module type; their poses over sim_time, every frame, every box.
        boxes = int(row["num_modules"] + row["num_hinges"])
        static = found[("/world/robot", True)]
        assert len(column(static, "Boxes3D:half_sizes")[0]) == boxes
        assert len(set(column(static, "Boxes3D:colors")[0])) == (
            1 + (row["num_bricks"] > 0) + 2 * (row["num_hinges"] > 0)
        )
        moving = found[("/world/robot", False)]
        assert moving.num_rows == FRAMES
        centers = column(moving, "Boxes3D:centers")
        quats = np.array(column(moving, "Boxes3D:quaternions"))
        assert all(len(frame) == boxes for frame in centers)
        assert np.allclose(np.linalg.norm(quats, axis=-1), 1.0, atol=1e-5)
        assert column(moving, "sim_time")[-1].total_seconds() == pytest.approx(0.5)
        # The core box follows the core's recorded path (the core geom is the first box).
        mine = traj[traj["eval_id"] == row["eval_id"]]
        core = np.array([frame[0] for frame in centers])
        path = mine[["core_x", "core_y", "core_z"]].to_numpy()
        assert np.allclose(core, path, atol=1e-5)
        # Joints: target and angle of every joint, named, equal to the trajectories table.
        colour_of: dict[str, dict] = {}
        for leaf, table_column in (("target", "joint_target"), ("angle", "joint_angle")):
            names = column(found[(f"/joints/{leaf}", True)], "SeriesLines:names")[0]
            body_graph = run.bodies.loc[run.bodies["body_id"] == row["body_id"], "graph"].iloc[0]
            assert names == joint_labels(row["joint_names"], body_graph)  # "left branch, hinge 2"
            assert all(re.fullmatch(r"(front|back|right|left) branch, hinge \d+", n) for n in names)
            series = np.array(column(found[(f"/joints/{leaf}", False)], "Scalars:scalars"))
            assert series.shape == (FRAMES, row["n_joints"])
            colours = column(found[(f"/joints/{leaf}", True)], "SeriesLines:colors")[0]
            assert len(set(colours)) == len(names)  # a colour per joint, the same in both
            colour_of.setdefault("target", dict(zip(names, colours, strict=True)))
            assert dict(zip(names, colours, strict=True)) == colour_of["target"]
            assert np.array_equal(series, np.stack(mine[table_column].to_numpy()))
        # Morphology graph: a node per module, a directed edge per attachment.
        graph = found[("/graph", True)]
        nodes = column(graph, "GraphNodes:node_ids")[0]
        assert len(nodes) == row["num_modules"]
        assert len(column(graph, "GraphEdges:edges")[0]) == row["num_modules"] - 1
        # Labels, short: a hinge as its joint's legend says ("right 1" for "right branch,
        # hinge 1"), the others by type alone; placed as a tree, the core on top.
        labels = column(graph, "GraphNodes:labels")[0]
        legend = joint_labels(row["joint_names"], body_graph)
        assert sorted(label for label in labels if HINGE.fullmatch(label)) == sorted(
            map(short, legend)
        )
        others = [label for label in labels if not HINGE.fullmatch(label)]
        assert others.count("core") == 1 and set(others) <= {"core", "brick"}
        positions = np.array(column(graph, "GraphNodes:positions")[0])
        assert positions.shape == (len(nodes), 2)
        assert len({tuple(p) for p in positions}) == len(nodes)  # no two nodes on one spot
        assert positions[labels.index("core")][1] == positions[:, 1].min()  # the core on top
        # Properties: the evaluation's ids and fitness; the world (floor) is drawn.
        props = found[("/__properties/ariel", True)]
        assert column(props, "eval_id")[0] == [row["eval_id"]]
        assert column(props, "body_id")[0] == [row["body_id"]]
        assert column(props, "fitness")[0] == [row["fitness"]]
        assert column(props, "generation")[0] == [row["generation"]]
        morphology = json.loads(column(props, "morphology")[0][0])
        assert morphology["num_modules"] == row["num_modules"]
        world = found[("/world", True)]
        assert "floor" in column(world, "Boxes3D:labels")[0]


def test_a_generation_recording_holds_every_evaluation_s_path_joints_graph_and_fitness(
    recorded,
) -> None:
    result, run = recorded
    shared = generation_recordings(result.run_dir)
    assert len(shared) == SMALL["generations"]
    traj = run.trajectories
    for path in shared:
        (entry,) = rr.chunk.RrdReader(path).recordings()
        assert entry.application_id == "ariel-generation"
        generation = int(path.parent.name.removeprefix("gen-"))
        mine = run.evaluations[
            (run.evaluations["generation"] == generation) & (run.evaluations["status"] == "ok")
        ].sort_values("eval_id")
        assert steps(path) == list(mine["eval_id"])
        found = chunks(path)
        assert column(found[("/fitness", False)], "Scalars:scalars") == [
            [f] for f in mine["fitness"]
        ]
        assert column(found[("/fitness", False)], "evaluation") == list(range(len(mine)))
        strips = column(found[("/world/trajectory", False)], "LineStrips3D:strips")
        targets = column(found[("/joints/target", False)], "LineStrips2D:strips")
        angles = column(found[("/joints/angle", False)], "LineStrips2D:strips")
        labels = column(found[("/joints/angle", False)], "LineStrips2D:labels")
        nodes = column(found[("/graph", False)], "GraphNodes:node_ids")
        node_labels = column(found[("/graph", False)], "GraphNodes:labels")
        for k, (_, row) in enumerate(mine.iterrows()):
            frames = traj[traj["eval_id"] == row["eval_id"]]
            core = frames[["core_x", "core_y", "core_z"]].to_numpy(np.float32)
            assert np.array_equal(np.array(strips[k][0]), core)
            assert len(targets[k]) == len(angles[k]) == len(labels[k]) == row["n_joints"]
            for j in range(row["n_joints"]):
                seconds, values = np.array(angles[k][j]).T
                assert np.array_equal(seconds, frames["t"].to_numpy(np.float32))
                expected = np.stack(frames["joint_angle"].to_numpy())[:, j].astype(np.float32)
                assert np.array_equal(values, expected)
            graph = run.bodies.loc[run.bodies["body_id"] == row["body_id"], "graph"].iloc[0]
            assert labels[k] == joint_labels(row["joint_names"], graph)
            hinges = sorted(label for label in node_labels[k] if HINGE.fullmatch(label))
            assert hinges == sorted(map(short, labels[k]))  # the hinges read as the legend
            assert len(nodes[k]) == row["num_modules"]


def test_run_rrd_holds_fitness_diversity_and_best_bodies_and_the_blueprint_reads_back(
    recorded,
) -> None:
    result, run = recorded
    found = chunks(result.run_dir / "run.rrd")
    generations = run.generations
    for name, entity in (
        ("best_fitness", "/fitness/best"),
        ("mean_fitness", "/fitness/mean"),
        ("median_fitness", "/fitness/median"),
    ):
        batch = found[(entity, False)]
        assert column(batch, "generation") == generations["generation"].tolist()
        values = [v[0] for v in column(batch, "Scalars:scalars")]
        assert np.allclose(values, generations[name].to_numpy(), equal_nan=True)
    diversity = [
        v[0] for v in column(found[("/diversity/descriptor_distance", False)], "Scalars:scalars")
    ]
    assert len(diversity) == 2 and all(d >= 0 for d in diversity)
    distinct = [
        v[0] for v in column(found[("/diversity/distinct_morphologies", False)], "Scalars:scalars")
    ]
    assert all(1 <= d <= 2 for d in distinct)  # population 2
    best = found[("/best/body", False)]
    texts = [t[0] for t in column(best, "TextDocument:text")]
    bodies = run.bodies[run.bodies["selected"]]
    for generation, text in zip(column(best, "generation"), texts):
        population = bodies[bodies["generation"] == generation]
        top = population.sort_values("fitness", ascending=False).iloc[0]
        assert text.startswith(top["body_id"])
    assert found[("/best/graph", False)].num_rows == len(texts)
    (blueprint,) = rr.chunk.RrdReader(result.run_dir / "blueprint.rbl").blueprints()
    assert blueprint.application_id == "ariel"
    layout = rr.chunk.RrdReader(result.run_dir / "blueprint.rbl").stream(store=blueprint)
    views, timelines = {}, []
    for chunk in layout.to_chunks():
        batch = chunk.to_record_batch()
        if "ViewBlueprint:display_name" in batch.schema.names:
            (name,) = column(batch, "ViewBlueprint:display_name")[0]
            (kind,) = column(batch, "ViewBlueprint:class_identifier")[0]
            views[name] = kind
        if "TimePanelBlueprint:timeline" in batch.schema.names:
            timelines += [t[0] for t in column(batch, "TimePanelBlueprint:timeline")]
    assert views["robot"] == "3D" and views["morphology"] == "Graph"
    assert views["joint angles (rad)"] == views["fitness (generation timeline)"] == "TimeSeries"
    # The run's fitness and diversity show beside an evaluation, whatever the timeline, one
    # view per series (a bar chart's legend could only show its entity path)...
    for name in (
        "best fitness per generation",
        "mean fitness per generation",
        "descriptor distance per generation",
        "distinct bodies per generation",
    ):
        assert views[name] == "BarChart"
    # ...and the viewer opens on the evaluation's clock, not on `generation`.
    assert timelines == ["sim_time"]
    summary = {key for key in found if key[0].startswith("/run/")}
    assert summary >= {("/run/fitness/best", True), ("/run/diversity/descriptor_distance", True)}
    assert all(static for _, static in summary)


def test_elites_replay_only_each_new_best_and_none_replays_nothing(tmp_path: Path) -> None:
    result = run_experiment(small(bodies="elites"), out=tmp_path / "elites")
    run = load_run(result.run_dir)
    files = recordings(result.run_dir)
    replayed = {
        eval_id for eval_id, path in files.items() if ("/world/robot", False) in chunks(path)
    }
    # A batch's best that beat its body's best so far: per body, the running record.
    expected = set()
    for _body_id, group in run.evaluations.groupby("body_id"):
        best = -math.inf
        for _, batch in group.groupby("iteration", sort=True):
            top = batch.loc[batch["fitness"].idxmax()]
            if top["fitness"] > best:
                best = top["fitness"]
                expected.add(top["eval_id"])
    assert replayed == expected
    assert set(run.bodies["best_eval_id"]) <= replayed
    assert set(files) == replayed  # the others: in evaluations.rrd; 3D made on demand
    assert len(run.evaluations) > len(replayed)
    for shared in generation_recordings(result.run_dir):
        generation = int(shared.parent.name.removeprefix("gen-"))
        mine = run.evaluations[run.evaluations["generation"] == generation]
        assert steps(shared) == sorted(mine["eval_id"])  # every evaluation, elites too

    none = run_experiment(small(bodies="none"), out=tmp_path / "none")
    assert not recordings(none.run_dir)
    assert len(generation_recordings(none.run_dir)) == SMALL["generations"]

    off = run_experiment(small(rerun=False), out=tmp_path / "off")
    assert not (off.run_dir / "recordings").exists()
    assert not (off.run_dir / "run.rrd").exists() and not (off.run_dir / "blueprint.rbl").exists()


def test_record_bodies_must_be_all_elites_or_none() -> None:
    with pytest.raises(ConfigError, match=r"record\.bodies"):
        load_config(small(bodies="best"))
    assert load_config({}).record.rerun is True and load_config({}).record.bodies == "elites"


def test_a_killed_writers_temporary_rrd_does_not_block_resume(
    recorded, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import ariel.recording.rerun._rerun as rerun_files

    out = tmp_path / "killed"
    original = rerun_files.atomic_write

    def killed_midway(path: Path, write: Any, **options: Any) -> None:
        # Generation 1's first recording: left half written under its temporary name, as
        # SIGKILL would leave it, and the run stops there.
        if Path(path).parent.name != "gen-000001" or Path(path).suffix != ".rrd":
            return original(path, write, **options)
        temporary = Path(path).with_name(f".{Path(path).name}.tmp")
        temporary.parent.mkdir(parents=True, exist_ok=True)
        write(temporary)
        data = temporary.read_bytes()
        temporary.write_bytes(data[: len(data) // 2])
        raise KeyboardInterrupt

    monkeypatch.setattr(rerun_files, "atomic_write", killed_midway)
    with pytest.raises(KeyboardInterrupt):
        run_experiment(small(), out=out)
    monkeypatch.setattr(rerun_files, "atomic_write", original)
    leftovers = list(out.rglob("*.rrd.tmp"))
    assert len(leftovers) == 1 and leftovers[0].parent.name == "gen-000001"
    assert load_run(out).info["generations_done"] == 1

    result = resume_experiment(out)
    assert result.status == "finished"
    run = load_run(out)
    files = recordings(out)
    assert set(files) == set(run.evaluations.loc[run.evaluations["status"] != "error", "eval_id"])
    assert not list(out.rglob("*.tmp"))
    for path in files.values():
        assert ("/world/robot", True) in chunks(path)  # every file whole and readable
    # run.rrd's lineage: generation 0's read back from its tables, as the uninterrupted run's
    assert lineage_rows(out / "run.rrd") == lineage_rows(recorded[0].run_dir / "run.rrd")


def test_write_evaluation_recording_draws_terrain_near_the_path_and_a_still_robot(
    tmp_path: Path,
) -> None:
    from ariel.evaluation import BodySpec, EvaluationTask, build, evaluate
    from ariel.plugins import controllers
    from ariel.recording.rerun._rerun import TERRAIN_MAX_SIDE, write_evaluation_recording

    def gecko_task(params: Any = ()) -> EvaluationTask:
        return EvaluationTask(
            body=BodySpec("prebuilt", "gecko"),
            params=params,
            world="rugged",
            duration=0.5,
            record_every=25,
            eval_id="gecko-on-hills",
        )

    built = build(gecko_task())
    n = controllers.make("na_cpg").num_parameters(built.model)
    task = gecko_task(np.random.default_rng(0).uniform(-1, 1, n))
    result = evaluate(task)
    assert result.body_pos is not None
    path = write_evaluation_recording(
        tmp_path / "gecko.rrd",
        model=built.model,
        body_names=result.body_names,
        result=result,
        properties={"eval_id": "gecko-on-hills", "fitness": result.fitness, "note": {"a": 1}},
        transforms=False,
    )
    found = chunks(path)
    vertices = np.array(column(found[("/world/floor", True)], "Mesh3D:vertex_positions")[0])
    assert 4 <= len(vertices) <= TERRAIN_MAX_SIDE**2 < 100 * 100
    core = result.core_pos[:, :2]
    assert vertices[:, 0].min() <= core[:, 0].min() and vertices[:, 0].max() >= core[:, 0].max()
    # transforms=False: the robot stands in its start pose, nothing moves; no graph given.
    assert ("/world/robot", False) not in found and ("/graph", True) not in found
    static = found[("/world/robot", True)]
    assert len(column(static, "Boxes3D:centers")[0]) == len(column(static, "Boxes3D:half_sizes")[0])
    props = found[("/__properties/ariel", True)]
    assert column(props, "note")[0] == ['{"a": 1}']


def test_discard_after_drops_the_recordings_of_unfinished_generations(tmp_path: Path) -> None:
    from ariel.recording import RunFolder

    for generation in (0, 1, 2):
        folder = tmp_path / "recordings" / f"gen-{generation:06d}"
        folder.mkdir(parents=True)
        (folder / f"b00000{generation}-i000-c000.rrd").write_bytes(b"rrd")
    (tmp_path / "recordings" / "gen-000002" / ".b000002-i000-c001.rrd.tmp").write_bytes(b"half")
    (tmp_path / "recordings" / "notes").mkdir()  # not a generation: left alone
    removed = RunFolder(tmp_path).discard_after(0)
    left = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*"))
    assert left == [
        "recordings",
        "recordings/gen-000000",
        "recordings/gen-000000/b000000-i000-c000.rrd",
        "recordings/notes",
    ]
    assert {p.name for p in removed} >= {"gen-000001", "gen-000002"}


def test_a_non_elite_s_3d_replay_on_demand_equals_the_all_recording(tmp_path: Path) -> None:
    """`ariel view RUN EVAL_ID` of an evaluation recorded without poses re-simulates it: the
    poses equal, bit for bit, those of the same evaluation in a run recording them all."""
    from ariel.recording.resim._replay import has_body_poses, on_demand_recording
    from ariel.recording.viewer._view import select_recordings

    everything = run_experiment(small(), out=tmp_path / "all").run_dir
    elites = run_experiment(small(bodies="elites"), out=tmp_path / "elites").run_dir
    run = load_run(elites)
    own = recordings(elites)
    others = run.evaluations[~run.evaluations["eval_id"].isin(list(own))]
    assert len(others) and all(has_body_poses(path) for path in own.values())
    for _, row in others.head(2).iterrows():
        eval_id = row["eval_id"]
        chosen = select_recordings(elites, eval_id=eval_id)
        (made,) = chosen.recordings
        folder = elites / "recordings" / f"gen-{row['generation']:06d}"
        assert made == folder / "replays" / f"{eval_id}.rrd"
        assert "on demand" in chosen.description and has_body_poses(made)
        assert on_demand_recording(elites, eval_id) == made  # cached
        mine, theirs = chunks(made), chunks(recordings(everything)[eval_id])
        for key in [("/world/robot", False), ("/world/robot", True), ("/joints/angle", False)]:
            for name in theirs[key].schema.names:
                if "RowId" not in name:
                    assert mine[key].column(name).equals(theirs[key].column(name)), (key, name)
        (entry,) = rr.chunk.RrdReader(made).recordings()
        assert entry.recording_id == eval_id
    assert not list(elites.rglob("*.tmp"))


def lineage_rows(path: Path) -> list[tuple[int, list[str], list[tuple[str, str]], list[Any]]]:
    """run.rrd's ``/lineage`` per generation: (generation, node ids, edges, node colours)."""
    batch = chunks(path)[("/lineage", False)]
    return [
        (generation, nodes, [(e["first"], e["second"]) for e in edges], colours)
        for generation, nodes, edges, colours in zip(
            column(batch, "generation"),
            column(batch, "GraphNodes:node_ids"),
            column(batch, "GraphEdges:edges"),
            column(batch, "GraphNodes:colors"),
        )
    ]


def test_run_rrd_rewritten_each_generation_makes_each_generation_s_graph_once(
    recorded, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The recorder rewrites run.rrd every generation; remaking every earlier generation's
    chunks each time took most of a long run (G^2/2 graph layouts: a 300-generation run spent
    73 % of its time recording). Its chunk cache makes each once, and the file is the same."""
    from ariel.recording.rerun import _rerun

    graphs = recorded[1].bodies["graph"].tolist()
    laid_out = []
    lay_out = _rerun.graph_archetypes
    monkeypatch.setattr(_rerun, "graph_archetypes", lambda g: laid_out.append(g) or lay_out(g))
    cache: dict[Any, Any] = {}
    for n in (1, 2, 3):
        done = {"generation": list(range(n)), "best_fitness": [0.1 * g for g in range(n)]}
        bests = {
            g: {"body_id": f"b{g:06d}", "fitness": 0.1 * g, "graph": graphs[g]} for g in range(n)
        }
        cached = _rerun.write_run_recording(tmp_path / f"{n}.rrd", done, bests, chunk_cache=cache)
    assert laid_out == graphs[:3]  # one per generation, not 1 + 2 + 3
    fresh = _rerun.write_run_recording(tmp_path / "fresh.rrd", done, bests)
    ours, theirs = chunks(cached)[("/best/graph", False)], chunks(fresh)[("/best/graph", False)]
    for name in ("generation", "GraphNodes:node_ids", "GraphNodes:labels", "GraphEdges:edges"):
        assert column(ours, name) == column(theirs, name), name
    assert column(ours, "generation") == [0, 1, 2]


def test_run_rrd_holds_the_lineage_graph_and_the_blueprint_a_view_of_it(recorded) -> None:
    result, run = recorded
    rows = lineage_rows(result.run_dir / "run.rrd")
    assert [g for g, *_ in rows] == list(range(SMALL["generations"]))
    for generation, nodes, edges, _ in rows:  # each generation: the bodies born so far
        bodies = run.bodies[run.bodies["born_generation"] <= generation]
        bodies = bodies.drop_duplicates("body_id")
        # one node per body, one edge per parent link (a body made from one parent twice: one)
        assert sorted(nodes) == sorted(bodies["body_id"]) and len(nodes) == len(set(nodes))
        links = {(p, b) for b, ps in zip(bodies["body_id"], bodies["parent_ids"]) for p in ps}
        assert sorted(edges) == sorted(links)
    assert rows[-1][2] and not rows[0][2]  # founders have no parents
    # Coloured by fitness: the fittest body bright yellow.
    _, nodes, _, colours = rows[-1]
    fitness = run.bodies.drop_duplicates("body_id").set_index("body_id")["fitness"]
    best = nodes.index(fitness.idxmax())
    assert colours[best] == 0xFDE725FF  # viridis' top, RGBA
    (blueprint,) = rr.chunk.RrdReader(result.run_dir / "blueprint.rbl").blueprints()
    layout = rr.chunk.RrdReader(result.run_dir / "blueprint.rbl").stream(store=blueprint)
    origins = {}
    for chunk in layout.to_chunks():
        batch = chunk.to_record_batch()
        if "ViewBlueprint:space_origin" in batch.schema.names:
            (name,) = column(batch, "ViewBlueprint:display_name")[0]
            origins[name] = column(batch, "ViewBlueprint:space_origin")[0][0]
    assert origins["lineage (bright: fitter)"] == "/lineage"


def test_a_brain_only_runs_mean_is_that_of_its_candidates_as_report_draws_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Its population is the one body, so run.rrd's mean (and the viewers') was its best again,
    where the progress line and `ariel report` show the mean of the CMA-ES candidates."""
    from ariel.evolution._progress import Progress
    from ariel.recording.viewer._view import _run_series

    config = small()
    config["body"] = {"encoder": "prebuilt", "genotype": "gecko", "options": {}}
    config["generations"] = 3
    original = Progress.start_generation

    def stop_at_2(self: Progress, generation: int, evaluations: int | None = None) -> None:
        if generation == 2:
            raise KeyboardInterrupt  # the resume summarises generations 0 and 1 from the tables
        original(self, generation, evaluations)

    with monkeypatch.context() as patch:
        patch.setattr(Progress, "start_generation", stop_at_2)
        with pytest.raises(KeyboardInterrupt):
            run_experiment(config, out=tmp_path / "run", progress=False)
    resume_experiment(tmp_path / "run", progress=False)
    run = load_run(tmp_path / "run")
    finite = run.evaluations[np.isfinite(run.evaluations["fitness"])]
    expected = finite.groupby("generation")["fitness"].mean().to_numpy()
    rows = []
    for chunk in rr.chunk.RrdReader(tmp_path / "run" / "run.rrd").stream().to_chunks():
        if chunk.entity_path == "/fitness/mean" and not chunk.is_static:
            batch = chunk.to_record_batch()
            rows += zip(
                batch.column("generation").to_pylist(), batch.column("Scalars:scalars").to_pylist()
            )
    recorded = np.array([v for _, v in sorted(rows)], dtype=float).ravel()
    np.testing.assert_allclose(recorded, expected)
    assert not np.allclose(recorded, run.generations["best_fitness"])
    np.testing.assert_allclose(_run_series(run)["mean_fitness"], expected)  # ariel view's
