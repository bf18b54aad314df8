"""What `ariel view` puts in each panel: the recording it opens holds what every view of its
layout shows (robot, morphology, joints, the run's charts, a MAP-Elites archive), the layout
has the views the run needs (an archive view only with an archive), and titles and legends
say what is plotted. Read back from the files, as the viewer gets them."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import networkx as nx
import numpy as np
import pandas as pd
import pytest

rr = pytest.importorskip("rerun")

from _helpers import TINY_QD, two_branches  # noqa: E402 - two_branches: test_joint_names' graph

from ariel.body_phenotypes.robogen_lite.graph_io import graph_to_plain  # noqa: E402
from ariel.evolution import run_experiment  # noqa: E402
from ariel.recording import load_run  # noqa: E402
from ariel.recording.rerun._joint_names import module_labels  # noqa: E402
from ariel.recording.rerun._rerun import (  # noqa: E402
    ARCHIVE_ENTITY,
    GRAPH_STEP,
    SUMMARY_SERIES,
    _graph_parts,
    tree_positions,
    write_blueprint,
)
from ariel.recording.store._axes import fitness_unit  # noqa: E402
from ariel.recording.viewer._view import _archive_beside, _prepared, select_recordings  # noqa: E402

BAR_VIEWS = {
    "best_fitness": "best fitness{unit} per generation",
    "mean_fitness": "mean fitness{unit} per generation",
    "diversity": "descriptor distance per generation",
    "distinct_morphologies": "distinct bodies per generation",
}


def _stored(graph: nx.DiGraph) -> str:
    """The graph as the bodies table stores it (node-link JSON)."""
    return json.dumps(nx.node_link_data(graph_to_plain(graph), edges="edges"))


def layout(path: Path) -> dict[str, dict[str, Any]]:
    """A saved blueprint's views: display name -> kind, origin and legend settings."""
    (store,) = rr.chunk.RrdReader(path).blueprints()
    by_id: dict[str, dict[str, Any]] = {}
    for chunk in rr.chunk.RrdReader(path).stream(store=store).to_chunks():
        parts = chunk.entity_path.strip("/").split("/")
        if parts[0] != "view":
            continue
        batch = chunk.to_record_batch()
        view = by_id.setdefault(parts[1], {})
        for name in batch.schema.names:
            if ":" in name:
                values = batch.column(name).to_pylist()[0]
                view[name] = values[0] if isinstance(values, list) and len(values) == 1 else values
    return {v["ViewBlueprint:display_name"]: v for v in by_id.values()}


def chunks_of(path: Path, *, static: bool = True) -> dict[str, Any]:
    """Entity path -> the record batch of its static chunk (``static=False``: of its chunk on
    a timeline); these recordings have at most one of each per entity."""
    return {
        c.entity_path: c.to_record_batch()
        for c in rr.chunk.RrdReader(path).stream().to_chunks()
        if c.entity_path not in ("/", "/__properties") and c.is_static == static
    }


def first(batch: Any, column: str) -> Any:
    return batch.column(column).to_pylist()[0]


# --- the morphology graph: short labels, drawn as a tree ---------------------------------------


def test_module_labels_are_short_and_read_as_the_joint_legends() -> None:
    graph = _stored(two_branches())
    ids, types, _ = _graph_parts(graph)
    labels = dict(zip(ids, module_labels(ids, types, graph)))
    assert labels == {
        "0": "core",
        "1": "right 1",  # the joint legends' "right branch, hinge 1"
        "2": "right 2",
        "3": "brick",
        "4": "front 2",
        "5": "front 1",
    }
    # Without a readable graph: a hinge by its module, the others by type.
    assert module_labels(["0", "7"], ["CORE", "HINGE"], "not json") == ["core", "hinge 7"]


def test_a_morphology_is_drawn_as_a_tree_with_room_for_its_labels() -> None:
    ids, _, edges = _graph_parts(_stored(two_branches()))
    at = dict(zip(ids, tree_positions(ids, edges)))
    step_x, step_y = GRAPH_STEP
    assert at["0"] == (0.0, 0.0)  # the core on top, in the middle
    depth = {"0": 0, "1": 1, "3": 1, "2": 2, "4": 2, "5": 2}
    assert {i: y for i, (x, y) in at.items()} == {i: d * step_y for i, d in depth.items()}
    # Leaves side by side, a label's width apart; a parent above the middle of its children.
    leaves = sorted(at[i][0] for i in ("2", "4", "5"))
    assert np.allclose(np.diff(leaves), step_x)
    assert at["3"][0] == pytest.approx((at["4"][0] + at["5"][0]) / 2)
    assert at["1"][0] == at["2"][0]
    # Not a tree (never a robot's): still no two nodes in one place.
    cyclic = tree_positions(["a", "b", "c"], [("a", "b"), ("b", "c"), ("c", "a")])
    assert len(set(cyclic)) == 3


# --- the layouts ------------------------------------------------------------------------------


def test_the_layout_has_an_archive_view_only_for_a_run_with_an_archive(tmp_path: Path) -> None:
    qd = layout(
        write_blueprint(tmp_path / "qd.rbl", archive=True, fitness_unit="m", run_curves=False)
    )
    (archive,) = [v for v in qd.values() if v["ViewBlueprint:class_identifier"] == "Tensor"]
    assert archive["ViewBlueprint:space_origin"] == ARCHIVE_ENTITY
    assert qd["robot"]["ViewBlueprint:class_identifier"] == "3D"
    assert qd["morphology"]["ViewBlueprint:class_identifier"] == "Graph"
    assert qd["joint angles (rad)"]["ViewBlueprint:class_identifier"] == "TimeSeries"
    # One bar chart per series (a bar chart's legend would name its entity path), titled with
    # its name and the fitness unit, without legend.
    for column, title in BAR_VIEWS.items():
        view = qd[title.format(unit=" (m)")]
        assert view["ViewBlueprint:class_identifier"] == "BarChart"
        assert view["ViewBlueprint:space_origin"] == SUMMARY_SERIES[column][0]
        assert view["PlotLegend:visible"] is False
    # The recordings beside which it opens have no generation timeline: no views of it.
    assert not [name for name in qd if "generation timeline" in name]

    ga = layout(write_blueprint(tmp_path / "ga.rbl"))  # the run's blueprint.rbl
    assert not [v for v in ga.values() if v["ViewBlueprint:class_identifier"] == "Tensor"]
    curves = ga["fitness (generation timeline)"]  # run.rrd's named curves, on generation
    assert curves["ViewBlueprint:class_identifier"] == "TimeSeries"
    assert curves["PlotLegend:corner"] == 1  # left top: Corner2D.LeftTop
    assert ga["descriptor distance"]["ViewBlueprint:space_origin"] == (
        "/diversity/descriptor_distance"
    )
    assert "best fitness per generation" in ga


# --- a MAP-Elites run, as `ariel view` opens it ---------------------------------------------------


@pytest.fixture(scope="module")
def qd_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("panels") / "qd"
    run_experiment(TINY_QD, out=out, progress=False)
    return out


def test_the_default_view_opens_the_best_evaluation_with_the_run_and_its_archive(
    qd_run: Path,
) -> None:
    run = load_run(qd_run)
    chosen = select_recordings(qd_run)
    assert chosen.overview is not None and chosen.beside_run
    with _prepared(chosen, panels=False) as shown:
        # One recording: given run.rrd as well, the viewer opens on that, whose robot,
        # morphology and joint panels are empty.
        (opened,) = shown.recordings
        (store,) = rr.chunk.RrdReader(opened).recordings()
        assert store.application_id == "ariel" and store.recording_id == chosen.overview.stem
        found = chunks_of(opened)
        # The robot (a 3D replay), its joints on sim_time, its morphology: drawn short, as a tree.
        assert {"/world/robot", "/joints/target", "/joints/angle", "/graph"} <= set(found)
        assert {"/world/robot", "/joints/angle"} <= set(chunks_of(opened, static=False))
        graph = found["/graph"]
        labels = first(graph, "GraphNodes:labels")
        assert "core" in labels and all(len(label) <= 8 for label in labels)
        assert len(first(graph, "GraphNodes:positions")) == len(labels)
        # The run's charts per generation, static (drawn whatever the timeline).
        generations = run.generations.rename(columns={"distinct_bodies": "distinct_morphologies"})
        for column, (entity, _, _) in SUMMARY_SERIES.items():
            (tensor,) = first(found[entity], "BarChart:values")
            if column in generations:  # diversity: run.rrd's own measure, not in the table
                assert np.allclose(tensor["buffer"], generations[column], equal_nan=True)
            assert len(tensor["buffer"]) == len(generations) == TINY_QD["generations"]
        # The archive after the last generation: the measures' names and ranges on its axes,
        # each elite's fitness in its cell, empty cells below every elite.
        (data,) = first(found[ARCHIVE_ENTITY], "Tensor:data")
        assert data["shape"] == [4, 4]
        assert data["names"] == ["num_limbs (0 to 4)", "joints_ratio (0 to 1)"]
        values = np.array(data["buffer"])
        archive = run.archive[run.archive["generation"] == run.archive["generation"].max()]
        assert np.allclose(values[archive["cell"]], archive["fitness"])
        empty = np.setdiff1d(np.arange(16), archive["cell"])
        assert len(empty) and (values[empty] < archive["fitness"].min()).all()
        (low, high) = first(found[ARCHIVE_ENTITY], "Tensor:value_range")[0]
        assert low == values[empty][0] and high == archive["fitness"].max()
        # Its layout: the archive view, the fitness unit in the titles, the panels collapsed.
        views = layout(shown.blueprint)
        tensors = [v for v in views.values() if v["ViewBlueprint:class_identifier"] == "Tensor"]
        assert [v["ViewBlueprint:space_origin"] for v in tensors] == [ARCHIVE_ENTITY]
        name = run.config["task"]["fitness"]
        unit = f" ({fitness_unit(name)})" if fitness_unit(name) else ""
        assert BAR_VIEWS["best_fitness"].format(unit=unit) in views
    assert not opened.exists()  # scratch, gone with the viewer


def test_best_k_and_one_evaluation_open_copies_with_the_run_s_charts(qd_run: Path) -> None:
    run = load_run(qd_run)
    for chosen in (
        select_recordings(qd_run, best=2),
        select_recordings(qd_run, eval_id=str(run.evaluations["eval_id"].iloc[0])),
    ):
        with _prepared(chosen) as shown:
            assert [p.name for p in shown.recordings] == [p.name for p in chosen.recordings]
            for opened in shown.recordings:
                found = chunks_of(opened)
                assert "/world/robot" in found and "/run/fitness/best" in found
                assert "/run/diversity/distinct_morphologies" in found and ARCHIVE_ENTITY in found
            views = layout(shown.blueprint)
            assert any(v["ViewBlueprint:space_origin"] == ARCHIVE_ENTITY for v in views.values())


def test_a_best_evaluation_without_its_own_recording_is_replayed_for_the_default_view(
    qd_run: Path, tmp_path: Path
) -> None:
    copy = tmp_path / "qd"
    shutil.copytree(qd_run, copy)
    own = select_recordings(copy).overview
    own.unlink()
    chosen = select_recordings(copy)
    assert chosen.overview is not None and chosen.overview.name == own.name
    assert chosen.overview.parent.name == "replays" and chosen.overview.is_file()
    assert chosen.recordings == (chosen.overview, copy / "run.rrd")


def test_a_generation_s_graph_is_drawn_as_a_tree(qd_run: Path) -> None:
    (shared,) = (qd_run / "recordings").glob("gen-*/evaluations.rrd")
    graph = chunks_of(shared, static=False)["/graph"]
    for labels, positions in zip(
        graph.column("GraphNodes:labels").to_pylist(),
        graph.column("GraphNodes:positions").to_pylist(),
    ):
        assert len(positions) == len(labels) and labels.count("core") == 1
        assert len({tuple(p) for p in positions}) == len(labels)


def test_the_archive_axes_come_from_the_config_or_the_defaults() -> None:
    rows = pd.DataFrame(
        {"generation": [0, 1, 1], "cell": [0, 1, 5], "fitness": [0.1, 0.2, 0.3]}
        | {"grid": [[2, 3]] * 3}
    )
    bare = SimpleNamespace(archive=rows, config={"body": {"optimizer_options": {}}})
    grid, names = _archive_beside(bare)
    assert names == ["num_limbs (0 to 8)", "joints_ratio (0 to 1)"]  # MapElites' defaults
    assert grid.shape == (2, 3) and np.nansum(grid) == pytest.approx(0.5)  # generation 1 only
    none = SimpleNamespace(archive=rows.iloc[:0], config={})
    assert _archive_beside(none) is None


# --- the campaign view --------------------------------------------------------------------------


def _campaign(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, maximise: bool) -> Path:
    """A campaign folder of two conditions x two seeds, its runs stood in for."""
    import ariel.recording.rerun._campaign_rerun as campaign_rerun

    folder = tmp_path / "campaign"
    folder.mkdir()
    runs = [
        {
            "condition": c,
            "seed": s,
            "path": f"runs/condition={c}/seed={s}",
            "config": {},
            "run_id": f"{c}-{s}",
        }
        for c in ("fresh", "inherit")
        for s in (1, 2)
    ]
    conditions = [{"name": "fresh"}, {"name": "inherit"}]
    info = {"format": 1, "campaign_id": "c", "conditions": conditions, "runs": runs}
    (folder / "campaign.json").write_text(json.dumps(info))

    def stand_in(seed: int) -> Any:
        evaluations = pd.DataFrame(
            {
                "generation": [0, 0, 1, 1],
                "eval_id": ["a", "b", "c", "d"],
                "fitness": np.array([0.1, 0.3, 0.2, 0.5]) * seed,
                "status": ["ok"] * 4,
            }
        )
        return SimpleNamespace(evaluations=evaluations, config={"task": {"fitness": "x_speed"}})

    fake = SimpleNamespace(
        path=folder,
        info=info,
        conditions=["fresh", "inherit"],
        runs={(r["condition"], r["seed"]): stand_in(r["seed"]) for r in runs},
        maximise=maximise,
    )
    monkeypatch.setattr(campaign_rerun, "load_campaign", lambda _: fake)
    return folder


@pytest.mark.parametrize(("maximise", "corner"), [(True, 1), (False, 3)])
def test_the_campaign_view_titles_its_axes_and_keeps_its_legend_small_and_aside(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, maximise: bool, corner: int
) -> None:
    from ariel.recording.rerun._campaign_rerun import CAMPAIGN_BLUEPRINT, write_campaign_recording

    folder = _campaign(tmp_path, monkeypatch, maximise)
    recording = write_campaign_recording(folder)
    # Every series is named after its condition: the legend lists each condition once.
    names = {
        path: first(batch, "SeriesLines:names")
        for path, batch in chunks_of(recording).items()
        if "SeriesLines:names" in batch.schema.names
    }
    assert names == {f"/condition/{c}/seed/{s}": [c] for c in ("fresh", "inherit") for s in (1, 2)}
    views = layout(folder / CAMPAIGN_BLUEPRINT)
    unit = fitness_unit("x_speed")
    axes = f"best fitness so far{f' ({unit})' if unit else ''} over evaluations"
    assert set(views) == {f"every run: {axes}", f"fresh: {axes}", f"inherit: {axes}"}
    # The legend in the corner the curves leave empty (top left when they rise, bottom left
    # when they fall); none where every curve has the condition's colour.
    assert views[f"every run: {axes}"]["PlotLegend:corner"] == corner
    assert views[f"fresh: {axes}"]["PlotLegend:visible"] is False
    assert views[f"inherit: {axes}"]["PlotLegend:visible"] is False
