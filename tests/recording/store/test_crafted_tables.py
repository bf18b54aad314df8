"""Table files crafted by a hostile probe, their manifests rewritten so that `ariel verify`
passes: each is refused in one line (`DamagedRunError` naming the file) or read as what it
means, never a traceback, never loaded as something no run wrote.

1. a null ``selected`` (no run writes one): one line, not pandas' "Cannot mask with
   non-boolean array containing NA";
2. a generation without a selected body: its population is empty (not ``KeyError: 'fitness'``);
3. a column the file lacks (not one added since runs were recorded): one line, not nulls;
4. joint lists of another length than the evaluation's joints: one line in `Run.joint_signals`;
5. an Arrow parse error quoting the file's bytes: escaped in the one line.
"""

from __future__ import annotations

import math
import shutil
from collections.abc import Callable
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from _helpers import exit_code, one_error_line, tiny_finished_run

from ariel.recording import DamagedRunError, load_run, verify_run
from ariel.recording.store._manifest import write_manifest
from ariel.recording.store._tables import read_table


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tiny_finished_run(tmp_path_factory, "crafted", 1)


def _crafted(
    run_dir: Path, to: Path, table: str, edit: Callable[[pa.Table], pa.Table], generation: int
) -> Path:
    """A copy of ``run_dir`` in ``to`` whose ``table`` file of ``generation`` is ``edit``ed,
    its manifest written again (`ariel verify` passes)."""
    shutil.copytree(run_dir, to)
    path = to / table / f"gen-{generation:06d}.parquet"
    pq.write_table(edit(pq.read_table(path)), path)
    write_manifest(to, generation)
    assert verify_run(to).problems == []
    return to


def _set(name: str, values: Callable[[pa.Table], pa.Array]) -> Callable[[pa.Table], pa.Table]:
    def edit(rows: pa.Table) -> pa.Table:
        column = values(rows)
        return rows.set_column(rows.schema.get_field_index(name), name, column)

    return edit


def test_a_null_selected_is_damage_in_one_line(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    nulls = _set("selected", lambda rows: pa.nulls(rows.num_rows, pa.bool_()))
    crafted = _crafted(run_dir, tmp_path / "run", "bodies", nulls, 1)
    with pytest.raises(DamagedRunError, match=r"bodies/gen-000001\.parquet has a null 'selected'"):
        load_run(crafted).generations  # noqa: B018
    for command in (["report", "--no-render", str(crafted)], ["compare", str(crafted)]):
        out = [] if command[0] == "report" else ["--out", str(tmp_path / "compared")]
        assert exit_code([*command, *out]) == 2, command
        assert "has a null 'selected' in its rows" in one_error_line(capsys), command


def test_a_generation_without_a_selected_body_has_an_empty_population(
    run_dir: Path, tmp_path: Path
) -> None:
    none = _set("selected", lambda rows: pa.array([False] * rows.num_rows))
    run = load_run(_crafted(run_dir, tmp_path / "run", "bodies", none, 1))
    generations = run.generations
    assert math.isnan(generations["best_fitness"].iloc[1])
    assert generations["distinct_bodies"].iloc[1] == 0
    assert set(run.population["generation"]) == {0}


def test_a_column_a_run_s_file_lacks_is_damage_not_nulls(run_dir: Path, tmp_path: Path) -> None:
    crafted = _crafted(
        run_dir, tmp_path / "run", "evaluations", lambda rows: rows.drop(["fitness"]), 1
    )
    expected = r"evaluations/gen-000001\.parquet has no column 'fitness' \(every run writes it\)"
    with pytest.raises(DamagedRunError, match=expected):
        load_run(crafted).evaluations  # noqa: B018
    # A bare table (no manifest) still reads a column it lacks as nulls.
    bare = tmp_path / "bare" / "evaluations" / "gen-000001.parquet"
    bare.parent.mkdir(parents=True)
    shutil.copy(crafted / "evaluations" / "gen-000001.parquet", bare)
    assert read_table(bare.parents[1], "evaluations").column("fitness").null_count > 0


def test_a_run_from_before_a_later_column_still_loads(run_dir: Path, tmp_path: Path) -> None:
    old = _crafted(run_dir, tmp_path / "run", "evaluations", lambda rows: rows.drop(["backend"]), 1)
    evaluations = load_run(old).evaluations
    assert set(evaluations.loc[evaluations["generation"] == 1, "backend"]) == {"mujoco"}


def test_joint_lists_not_one_value_per_joint_are_damage(run_dir: Path, tmp_path: Path) -> None:
    def ragged(rows: pa.Table) -> pa.Array:
        lists = [[] if i % 3 == 0 else None if i % 3 == 1 else [0.1] * 50 for i in range(len(rows))]
        return pa.array(lists, pa.list_(pa.float64()))

    crafted = _crafted(run_dir, tmp_path / "run", "trajectories", _set("joint_angle", ragged), 1)
    run = load_run(crafted)
    eval_id = run.evaluations.loc[run.evaluations["generation"] == 1, "eval_id"].iloc[0]
    expected = r"trajectories/gen-000001\.parquet has joint_angle lists of evaluation .* not one"
    with pytest.raises(DamagedRunError, match=expected):
        run.joint_signals(eval_id)


def test_an_arrow_parse_error_quoting_the_file_is_escaped(run_dir: Path, tmp_path: Path) -> None:
    text = _set("fitness", lambda rows: pa.array(["[/bold]\x1b[2J\u202e"] * rows.num_rows))
    crafted = _crafted(run_dir, tmp_path / "run", "evaluations", text, 1)
    with pytest.raises(DamagedRunError) as raised:
        load_run(crafted).evaluations  # noqa: B018
    message = str(raised.value)
    assert "Failed to parse string: '[/bold]\\x1b[2J\\u202e'" in message
    assert message.isprintable()


def test_a_generation_file_named_with_other_scripts_digits_is_no_generation(
    tmp_path: Path,
) -> None:
    """``\\d`` took Arabic-Indic digits: ``gen-٠٠٠٠٠١.parquet`` was read as generation 1
    beside ``gen-000001.parquet``."""
    from ariel.recording.store._tables import table_generations

    folder = tmp_path / "evaluations"
    folder.mkdir()
    (folder / "gen-000001.parquet").write_bytes(b"")
    (folder / "gen-\u0660\u0660\u0660\u0660\u0660\u0661.parquet").write_bytes(b"")
    assert table_generations(tmp_path, "evaluations") == [1]
