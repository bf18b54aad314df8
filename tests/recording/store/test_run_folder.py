"""Run folders: creation rules and crash leftovers."""

from __future__ import annotations

from pathlib import Path

import pytest

from ariel.recording import RunFolder
from ariel.recording.store._files import (
    atomic_write,
    atomic_write_bytes,
    remove_temporaries,
    written_path,
)


def test_a_folder_killed_while_being_created_may_be_reused(tmp_path: Path) -> None:
    out = tmp_path / "run"
    out.mkdir()
    (out / ".run.json.tmp").write_text('{"form')  # a writer killed before its rename
    RunFolder.check_new(out, overwrite=False)  # counts as empty
    RunFolder.create(out, {"run_id": "run"}, overwrite=False)
    assert RunFolder(out).read_info()["run_id"] == "run"
    assert not (out / ".run.json.tmp").exists()


def test_overwrite_replaces_only_run_folders(tmp_path: Path) -> None:
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "thesis.tex").write_text("x")
    with pytest.raises(FileExistsError, match="already exists"):
        RunFolder.check_new(mine, overwrite=False)
    with pytest.raises(FileExistsError, match="not an ariel run folder"):
        RunFolder.check_new(mine, overwrite=True)
    run = tmp_path / "run"
    RunFolder.create(run, {"run_id": "a"}, overwrite=False)
    RunFolder.create(run, {"run_id": "b"}, overwrite=True)
    assert RunFolder(run).read_info()["run_id"] == "b"


def test_atomic_writes_leave_no_temporary_and_leftovers_are_removed(tmp_path: Path) -> None:
    target = tmp_path / "sub" / "file.bin"
    atomic_write_bytes(target, b"abc")
    assert target.read_bytes() == b"abc"
    assert [p.name for p in target.parent.iterdir()] == ["file.bin"]
    (target.parent / ".gen-000001.parquet.tmp").write_bytes(b"half")  # before the token
    (target.parent / ".gen-000002.parquet.0123abcd.tmp").write_bytes(b"half")
    removed = sorted(p.name for p in remove_temporaries(tmp_path))
    assert removed == [".gen-000001.parquet.tmp", ".gen-000002.parquet.0123abcd.tmp"]
    assert [p.name for p in target.parent.iterdir()] == ["file.bin"]
    assert written_path(target.parent / ".gen-000002.parquet.0123abcd.tmp") == (
        target.parent / "gen-000002.parquet"
    )


def test_two_writers_of_one_file_do_not_share_a_temporary(tmp_path: Path) -> None:
    """Two ``ariel report`` of one run: the second writer's start used to delete the first's
    temporary ("cannot write 'report/fitness.png': No such file or directory")."""
    target = tmp_path / "fitness.png"

    def first(temporary: Path) -> None:
        temporary.write_bytes(b"first")
        atomic_write_bytes(target, b"second")  # the other process, while this one writes

    atomic_write(target, first)
    assert target.read_bytes() == b"first"  # the last rename wins, and nothing failed
    assert [p.name for p in tmp_path.iterdir()] == ["fitness.png"]


def test_csv_cells_a_spreadsheet_would_evaluate_are_quoted_and_no_others() -> None:
    """Before, a table's "-" (no better condition in compare's stats.csv) read back in pandas
    as "'-"; a formula must still never reach a spreadsheet."""
    import pandas as pd

    from ariel.recording.store._escape import csv_safe

    cells = ["-", "+", "-0.5", "-1e5", "=1+1", "-2+3+cmd|' /C calc'!A0", "@SUM(A1)", "\t-1", " -1"]
    assert csv_safe(pd.DataFrame({"cell": cells}))["cell"].tolist() == [
        "-",
        "+",
        "-0.5",
        "-1e5",
        "'=1+1",
        "'-2+3+cmd|' /C calc'!A0",
        "'@SUM(A1)",
        "'\t-1",
        " -1",
    ]


@pytest.mark.parametrize(
    ("name", "said"),
    [("cafe\u0301", "(it holds '\u0301', U+0301)"), ("a\N{GRINNING FACE}", "U+1F600)")],
)
def test_a_name_that_cannot_be_a_run_id_names_its_character(name: str, said: str) -> None:
    """An accent written as a combining mark was refused as "a run id is letters, ...", and
    it looks like a letter: the line names the character (probe G4)."""
    from ariel.errors import ConfigError
    from ariel.recording.store import check_new_id

    with pytest.raises(ConfigError) as refused:
        check_new_id(name)
    assert said in str(refused.value) and "a run id is letters, digits" in str(refused.value)
    assert check_new_id("caf\u00e9") == "caf\u00e9"  # the composed é is a letter


def test_a_run_folder_without_room_for_its_deepest_file_is_refused_before_it_is_made(
    tmp_path: Path,
) -> None:
    """An --out of 4,060 bytes (every name short) was made, and the run died writing a
    recording deeper in it, leaving a half-made run (probe G4)."""
    import errno

    from ariel.recording.store._files import DEEPEST_IN_RUN, PATH_MAX, check_path_names

    room = PATH_MAX - len(str(tmp_path)) - len(DEEPEST_IN_RUN) - 2  # for the folder's names
    fits = tmp_path.joinpath(*["a" * 200] * (room // 201))
    check_path_names(fits)  # within PATH_MAX with its deepest file: taken
    too_long = tmp_path.joinpath(*["c" * 200] * (room // 201 + 1))
    with pytest.raises(OSError) as refused:
        check_path_names(too_long)
    assert refused.value.errno == errno.ENAMETOOLONG and refused.value.filename.endswith(".tmp")
    assert not (tmp_path / ("c" * 200)).exists()
