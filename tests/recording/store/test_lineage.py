"""A run's lineage in the ALife data standard's phylogeny format: every body reaches a founder
of generation 0, the CSV reads back through phylotrackpy with the same ancestry, and the
per-generation statistics match a lineage worked out by hand."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _helpers import tiny_run_toml

import ariel
from ariel.recording import load_run
from ariel.recording.store._lineage import (
    LINEAGE_COLUMNS,
    ancestors,
    format_ancestor_list,
    lineage,
    lineage_statistics,
    lineage_statistics_by_run,
    parse_ancestor_list,
    write_lineage_csv,
)


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory):
    """A tiny run of 4 generations without crossover (phylotrackpy reads one parent each)."""
    folder = tmp_path_factory.mktemp("lineage")
    config = folder / "tiny.toml"
    config.write_text(tiny_run_toml("lineage", 3, generations=4))
    out = folder / "run"
    ariel.run_experiment(config, out=out, progress=False, overrides=["body.crossover_rate=0"])
    return load_run(out)


@pytest.fixture(scope="module")
def frame(run):
    return lineage(run)


def test_every_body_is_a_taxon_whose_ancestors_reach_generation_0(run, frame) -> None:
    assert list(frame.columns[: len(LINEAGE_COLUMNS)]) == list(LINEAGE_COLUMNS)
    assert sorted(frame["body_id"]) == sorted(run.bodies["body_id"].unique())
    assert frame["id"].tolist() == [int(b[1:]) for b in frame["body_id"]]
    origin = dict(zip(frame["id"], frame["origin_time"]))
    founders = {i for i, text in zip(frame["id"], frame["ancestor_list"]) if text == "[none]"}
    assert founders and {origin[i] for i in founders} == {0}
    for taxon in frame["id"]:
        chain = ancestors(frame, int(taxon))
        if taxon in founders:
            assert chain == []
            continue
        assert chain[-1] in founders  # asexual: parent, grandparent, ..., a founder
        times = [origin[taxon], *(origin[i] for i in chain)]
        assert times == sorted(times, reverse=True) and times[-1] == 0


def test_a_body_lives_while_it_is_in_the_population_after_selection(run, frame) -> None:
    kept = run.bodies[run.bodies["selected"]]
    end = frame["destruction_time"].astype("Float64").fillna(np.inf)
    for generation in range(run.generations_done):
        alive = (frame["origin_time"] <= generation) & (generation < end)
        in_population = kept.loc[kept["generation"] == generation, "body_id"]
        assert sorted(frame.loc[alive, "body_id"]) == sorted(in_population)
    done = np.cumsum(run.generations["evaluations"].to_numpy())
    assert frame["origin_evaluation"].tolist() == [done[t] for t in frame["origin_time"]]
    dead = frame["destruction_time"].notna()
    assert frame["destruction_evaluation"].isna().tolist() == (~dead).tolist()
    assert frame.loc[dead, "destruction_evaluation"].tolist() == [
        done[t] for t in frame.loc[dead, "destruction_time"]
    ]


def test_the_best_of_each_generation_is_the_runs_best(run, frame) -> None:
    stats = lineage_statistics(frame)
    assert stats["generation"].tolist() == list(range(run.generations_done))
    assert stats["best_fitness"].tolist() == run.generations["best_fitness"].tolist()
    assert stats["surviving_lineages"].iloc[0] == run.config["body"]["population"]
    for best, depth in zip(stats["best_id"], stats["best_depth"]):
        assert depth == len(ancestors(frame, int(best)))  # asexual: the chain's length


def test_the_csv_reads_back_through_phylotrackpy_with_the_same_ancestry(
    frame, tmp_path: Path
) -> None:
    systematics = pytest.importorskip("phylotrackpy.systematics")
    path = write_lineage_csv(frame, tmp_path / "phylogeny.csv", still_alive="inf")
    tracker = systematics.Systematics(lambda org: org, True, True, True, False)
    tracker.load_from_file(str(path), "id", False)
    taxa = [*tracker.get_active_taxa(), *tracker.get_ancestor_taxa(), *tracker.get_outside_taxa()]
    read = {t.get_id(): (t.get_parent().get_id() if t.get_parent() else None) for t in taxa}
    written = {
        int(i): (parse_ancestor_list(a) or [None])[0]
        for i, a in zip(frame["id"], frame["ancestor_list"])
    }
    assert read == written
    alive = {t.get_id() for t in tracker.get_active_taxa()}
    assert alive == set(frame.loc[frame["destruction_time"].isna(), "id"])
    assert {t.get_id(): t.get_origination_time() for t in taxa} == dict(
        zip(frame["id"], frame["origin_time"].astype(float))
    )


def test_the_csv_is_the_standards_and_is_never_overwritten_unasked(tmp_path: Path) -> None:
    frame = hand_made()
    path = write_lineage_csv(frame, tmp_path / "phylogeny.csv")
    lines = path.read_text().splitlines()
    assert lines[0].startswith("id,ancestor_list,origin_time,destruction_time")
    assert lines[1].startswith("0,[none],0,2,")
    assert lines[6].startswith('5,"[3, 4]",2,3,')
    assert lines[7].startswith("6,[3],3,,")  # still alive: an empty cell
    back = pd.read_csv(path)
    assert back["ancestor_list"].tolist() == frame["ancestor_list"].tolist()
    with pytest.raises(FileExistsError, match="overwrite=True"):
        write_lineage_csv(frame, path)
    write_lineage_csv(frame, path, overwrite=True, still_alive="none")
    assert path.read_text().splitlines()[7].startswith("6,[3],3,none,")
    assert [p.name for p in tmp_path.iterdir()] == ["phylogeny.csv"]  # no temporary left
    # A text cell a spreadsheet would run, or that clears a terminal, is written inert (as
    # compare's CSVs are): before, a crafted status reached the file as it was.
    frame["status"] = ['=HYPERLINK("x")\x1b[2J'] + ["ok"] * (len(frame) - 1)
    write_lineage_csv(frame, path, overwrite=True)
    text = path.read_text()
    assert "\x1b" not in text and '"\'=HYPERLINK(""x"")\\x1b[2J"' in text


def test_ancestor_lists_read_the_forms_tools_write() -> None:
    assert format_ancestor_list([3, 7]) == "[3, 7]" and format_ancestor_list([]) == "[none]"
    for text, ids in [("[none]", []), ("[NONE]", []), ("['none']", []), ("[3, 7]", [3, 7])]:
        assert parse_ancestor_list(text) == ids
    assert parse_ancestor_list("['3', '7']") == [3, 7]
    with pytest.raises(ValueError, match="not an ancestor_list"):
        parse_ancestor_list("3, 7")


def hand_made() -> pd.DataFrame:
    """Founders 0, 1, 2 (2 discarded by its own selection); 3 <- 0, 4 <- 1, 5 <- 3 and 4, 6 <- 3
    (alive, no fitness), 7 <- 5 (discarded at once). Alive per generation (origin <= g < end):
    0: {0, 1}, 1: {0, 3, 4}, 2: {3, 5}, 3: {6}."""
    return pd.DataFrame(
        {
            "id": [0, 1, 2, 3, 4, 5, 6, 7],
            "ancestor_list": ["[none]", "[none]", "[none]", "[0]", "[1]", "[3, 4]", "[3]", "[5]"],
            "origin_time": [0, 0, 0, 1, 1, 2, 3, 3],
            "destruction_time": pd.array([2, 1, 0, 3, 2, 3, None, 3], dtype="Int64"),
            "fitness": [1.0, 3.0, 9.0, 2.0, 5.0, 4.0, math.nan, 10.0],
        }
    )


def test_statistics_match_a_lineage_worked_out_by_hand() -> None:
    frame = hand_made()
    stats = lineage_statistics(frame, maximise=True, generations=4)
    assert stats["generation"].tolist() == [0, 1, 2, 3]
    assert stats["alive"].tolist() == [2, 3, 2, 1]
    # founders with a living descendant: {0, 1}, {0 (0, 3), 1 (4)}, {0, 1} (5 has both), {0}
    assert stats["surviving_lineages"].tolist() == [2, 2, 2, 1]
    assert stats["best_id"].tolist() == [1, 4, 5, pd.NA]
    assert stats["best_fitness"].tolist()[:3] == [3.0, 5.0, 4.0]
    assert math.isnan(stats["best_fitness"].iloc[3])  # the one living body has no fitness
    # 1 is a founder; 4 <- 1; 5 <- 3 <- 0 (the longest chain)
    assert stats["best_depth"].tolist() == [0, 1, 2, pd.NA]
    lowest = lineage_statistics(frame, maximise=False, generations=4)
    assert lowest["best_id"].tolist()[:3] == [0, 0, 3]
    # without the run's length: up to the last generation a body was made or alive in
    assert len(lineage_statistics(frame, maximise=True)) == 4
    with pytest.raises(ValueError, match="maximise="):
        lineage_statistics(frame)


def test_ancestors_are_listed_nearest_first_each_once() -> None:
    frame = hand_made().assign(body_id=[f"b{i:06d}" for i in range(8)])
    assert ancestors(frame, 7) == [5, 3, 4, 0, 1]
    assert ancestors(frame, "b000006") == [3, 0]
    assert ancestors(frame, 2) == []
    with pytest.raises(KeyError):
        ancestors(frame, 99)


def test_a_run_folder_or_what_is_no_lineage_is_one_line(run) -> None:
    with pytest.raises(TypeError, match=r"^lineage takes a run, load_run\(path\), not the path '"):
        lineage(str(run.path))  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"not a lineage: the frame has no column 'id'; pass "):
        ancestors(run.evaluations, 1)
    with pytest.raises(TypeError, match=r"not a lineage but a str: pass lineage\(run\)"):
        lineage_statistics("data/runs/x", maximise=True)  # type: ignore[arg-type]


def test_a_campaigns_statistics_are_one_table_by_run_id() -> None:
    frame = hand_made()
    stats = lineage_statistics_by_run({"a-s1": frame, "a-s2": frame}, maximise=True)
    assert stats.columns[0] == "run_id"
    assert stats["run_id"].tolist() == ["a-s1"] * 4 + ["a-s2"] * 4
    assert stats["surviving_lineages"].tolist() == [2, 2, 2, 1] * 2
    with pytest.raises(TypeError, match=r"takes run id -> lineage \(a dict, as campaign_line"):
        lineage_statistics_by_run([frame])  # type: ignore[arg-type]


def test_a_cycle_is_refused() -> None:
    frame = pd.DataFrame(
        {
            "id": [0, 1, 2],
            "ancestor_list": ["[none]", "[2]", "[1]"],
            "origin_time": [0, 1, 1],
            "destruction_time": pd.array([None] * 3, dtype="Int64"),
            "fitness": [1.0, 2.0, 3.0],
        }
    )
    with pytest.raises(ValueError, match="cycle"):
        lineage_statistics(frame, maximise=True)


def test_a_parent_that_is_no_body_of_the_run_is_a_damaged_run(run) -> None:
    from types import SimpleNamespace

    from ariel.errors import DamagedRunError

    bodies = run.bodies.copy()
    bodies["parent_ids"] = [["b999999"] if len(p) else p for p in bodies["parent_ids"]]
    crafted = SimpleNamespace(
        bodies=bodies,
        evaluations=run.evaluations,
        generations_done=run.generations_done,
        maximise=run.maximise,
        path=run.path,
    )
    with pytest.raises(DamagedRunError, match="b999999"):
        lineage(crafted)


def test_a_campaigns_lineages_are_keyed_by_run_id(run, frame) -> None:
    from types import SimpleNamespace

    from ariel.recording.store._lineage import campaign_lineages

    lineages = campaign_lineages(SimpleNamespace(runs={("default", 3): run}))
    assert list(lineages) == [run.info["run_id"]]
    pd.testing.assert_frame_equal(lineages[run.info["run_id"]], frame)
