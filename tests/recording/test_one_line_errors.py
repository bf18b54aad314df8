"""A bad situation or a crafted run folder ends in one line naming what is wrong (exit 2),
never a traceback: a full or read-only disk under `ariel report` / `export`, an export folder
behind a dangling link, a table's row or cell changed (controller parameters of the wrong
length, JSON nested out of stack), names with terminal control sequences or markup, TOML
nested too deeply."""

from __future__ import annotations

import errno
import shutil
from pathlib import Path
from typing import Any

import pytest
from _helpers import (
    edit_json,
    exit_code,
    one_error_line,
    tiny_finished_run,
    with_run_id,
)

from ariel.errors import DamagedRunError
from ariel.recording import load_run
from ariel.utils import ariel_line

DEEP = "[" * 100_000 + "]" * 100_000


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tiny_finished_run(tmp_path_factory, "one_line", 3)


@pytest.fixture
def copy(run_dir: Path, tmp_path: Path) -> Path:
    """A copy of the run, to change."""
    return Path(shutil.copytree(run_dir, tmp_path / "run"))


def _best(run: Path) -> dict[str, Any]:
    return load_run(run).evaluations.sort_values("fitness").iloc[-1].to_dict()


def _craft(run: Path, table: str, column: str, value: Any) -> dict[str, Any]:
    """Set ``column`` of the best evaluation's row (of its body's, in ``bodies``) to ``value``
    and write the generation's manifest again, as a crafter would; returns the best row."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from ariel.recording.store._manifest import write_manifest

    best = _best(run)
    generation = int(best["generation"])
    key = "eval_id" if table == "evaluations" else "body_id"
    path = run / table / f"gen-{generation:06d}.parquet"
    data = pq.read_table(path)
    values = [
        value if k == best[key] else v
        for k, v in zip(data.column(key).to_pylist(), data.column(column).to_pylist())
    ]
    index = data.schema.get_field_index(column)
    field = data.schema.field(index)
    pq.write_table(data.set_column(index, field, pa.array(values, field.type)), path)
    write_manifest(run, generation)
    return best


# --- a full or read-only disk ------------------------------------------------------------------


@pytest.mark.parametrize("number", [errno.ENOSPC, errno.EROFS, errno.EACCES])
def test_report_on_a_disk_that_refuses_writes_is_one_line_and_leaves_no_part_of_a_file(
    copy: Path, number: int, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from matplotlib.figure import Figure

    def fail(self: Any, path: Any, **kwargs: Any) -> None:
        Path(path).write_bytes(b"\x89PNG half")  # a part written, then the disk refuses
        raise OSError(number, "refused")

    monkeypatch.setattr(Figure, "savefig", fail)
    assert exit_code(["report", str(copy), "--no-render"]) == 2
    line = one_error_line(capsys)
    import os

    assert f"cannot write {str(copy / 'report' / 'fitness.png')!r}: {os.strerror(number)}" in line
    assert "ariel report" in line  # what to run once there is room
    # no temporary, no half a figure: and report/, which this call made, is gone again
    assert not (copy / "report").exists() or list((copy / "report").iterdir()) == []


def test_report_on_a_read_only_run_folder_is_one_line(
    copy: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    mkdir = Path.mkdir

    def refuse(self: Path, *args: Any, **kwargs: Any) -> None:
        if self.name == "report":
            raise OSError(errno.EROFS, "Read-only file system", str(self))
        mkdir(self, *args, **kwargs)

    monkeypatch.setattr(Path, "mkdir", refuse)
    assert exit_code(["report", str(copy), "--no-render"]) == 2
    line = one_error_line(capsys)
    assert f"cannot write {str(copy / 'report')!r}: Read-only file system" in line
    assert line.endswith(f"or write it elsewhere: {ariel_line('report', copy, '--out', 'DIR')}")


def test_compare_on_a_full_disk_is_one_line(
    copy: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from matplotlib.figure import Figure

    other = Path(shutil.copytree(copy, tmp_path / "other"))
    with_run_id(copy, "one_line-a")
    with_run_id(other, "one_line-b")

    def full(self: Any, path: Any, **kwargs: Any) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Figure, "savefig", full)
    out = tmp_path / "compared"
    argv = ["compare", str(copy), str(other), "--label", f"a={copy}", "--label", f"b={other}"]
    assert exit_code([*argv, "--out", str(out)]) == 2
    assert "No space left on device" in one_error_line(capsys)
    assert not any(p.is_file() and p.suffix == ".png" for p in out.rglob("*"))


# --- export: a dangling link on the way, a read-only file system -------------------------------


def test_export_behind_a_dangling_link_is_one_line(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    dangling = tmp_path / "dangling"
    dangling.symlink_to(tmp_path / "nowhere")
    for out in (dangling / "x", dangling / "x" / "y"):
        assert exit_code(["export", str(run_dir), "best", str(out)]) == 2
        line = one_error_line(capsys)
        assert f"{str(dangling)!r} is a symbolic link to {str(tmp_path / 'nowhere')!r}" in line
    assert exit_code(["export", str(run_dir), "best", str(dangling)]) == 2  # the link itself
    assert "is a symbolic link" in one_error_line(capsys)
    (tmp_path / "file").write_text("mine")
    assert exit_code(["export", str(run_dir), "best", str(tmp_path / "file" / "x")]) == 2
    assert "is not a folder" in one_error_line(capsys)
    assert not (tmp_path / "nowhere").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dangling", "file"]


def test_export_onto_a_read_only_file_system_is_one_line_and_exports_nothing(
    run_dir: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    import ariel.recording.store as store  # `ariel export` takes it from the package's face

    write = store.atomic_write
    written: list[str] = []

    def read_only_after_two(path: Path, *args: Any, **kwargs: Any) -> None:
        if len(written) == 2:
            raise OSError(errno.EROFS, "Read-only file system", str(path))
        write(path, *args, **kwargs)
        written.append(path.name)

    monkeypatch.setattr(store, "atomic_write", read_only_after_two)
    out = tmp_path / "x"
    assert exit_code(["export", str(run_dir), "best", str(out)]) == 2
    line = one_error_line(capsys)
    assert f"cannot write {str(out / 'controller.json')!r}: Read-only file system" in line
    assert written == ["body.xml", "genotype.json"] and not out.exists()  # all or nothing


# --- a changed row: controller parameters of the wrong length ---------------------------------


def test_replay_and_export_of_parameters_of_the_wrong_length_are_one_line(
    copy: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    needed = len(_best(copy)["controller_params"])
    best = _craft(copy, "evaluations", "controller_params", [0.5, 0.25])
    expected = f"evaluation {best['eval_id']!r} of run {str(copy)!r}: its row holds 2 controller "
    assert exit_code(["replay", str(copy), "best"]) == 2
    line = one_error_line(capsys, quiet=True)
    assert line.startswith(f"ariel: error: {expected}") and f"needs {needed} (" in line
    assert exit_code(["export", str(copy), "best", str(tmp_path / "x")]) == 2
    assert expected in one_error_line(capsys) and not (tmp_path / "x").exists()

    # `ariel view RUN EVAL_ID` re-simulates an evaluation without its own recording so: the
    # same error, a ValueError, which view reports in one line
    from ariel.recording.resim._replay import on_demand_recording

    with pytest.raises(DamagedRunError, match=f"needs {needed} "):
        on_demand_recording(copy, best["eval_id"])

    # report draws the best body only: its parameters are not needed
    assert exit_code(["report", str(copy)]) == 0


def test_replay_of_parameters_that_are_not_numbers_is_one_line(
    copy: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    best = _craft(copy, "evaluations", "controller_params", None)
    assert exit_code(["replay", str(copy), best["eval_id"]]) == 2
    assert "not a list of finite numbers" in one_error_line(capsys)


# --- JSON nested out of stack ------------------------------------------------------------------


def test_a_genotype_cell_nested_out_of_stack_is_one_line(
    copy: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    best = _craft(copy, "evaluations", "body_genotype", DEEP)
    for argv in (["replay", str(copy), "best"], ["export", str(copy), "best", str(tmp_path / "x")]):
        assert exit_code(argv) == 2
        line = one_error_line(capsys)
        assert f"evaluation {best['eval_id']!r}" in line
        assert "body_genotype is not readable JSON (JSON nested more than 100 deep)" in line
    assert exit_code(["report", str(copy)]) == 0  # the rest of the report stands
    assert "best_body.png: left out (evaluation" in capsys.readouterr().out


def test_a_graph_nested_out_of_stack_is_refused(copy: Path) -> None:
    from ariel.recording.rerun._joint_names import joint_labels
    from ariel.recording.rerun._rerun import _graph_parts
    from ariel.recording.resim._replay import on_demand_recording, replay

    best = _best(copy)
    replayed = replay(copy, best["eval_id"])  # before: the graph is not needed to replay
    graph = _craft(copy, "bodies", "graph", DEEP)
    replayed.run = load_run(copy)
    with pytest.raises(DamagedRunError, match=r"graph is not readable JSON .*nested more"):
        replayed.graph_json()  # what --rrd writes
    with pytest.raises(DamagedRunError, match="graph is not readable JSON"):
        on_demand_recording(copy, graph["eval_id"])  # ariel view RUN EVAL_ID
    names = ["joint-a", "joint-b"]
    assert joint_labels(names, DEEP) == joint_labels(names, None)  # as without a graph
    with pytest.raises(ValueError, match="nested more than 100"):
        _graph_parts(DEEP)
    # The generations table counts distinct graphs (report, compare): one line there too.
    with pytest.raises(DamagedRunError, match=r"its graph cell is not a robot graph"):
        load_run(copy).generations  # noqa: B018 - the property reads the cell


def test_an_export_folder_nested_out_of_stack_is_one_line(run_dir: Path, tmp_path: Path) -> None:
    from ariel.recording import load_exported
    from ariel.recording.resim._export import export

    out = export(run_dir, "best", tmp_path / "x")
    for name, text in (("controller.json", DEEP), ("genotype.json", "[1]")):
        kept = (out / name).read_text()
        (out / name).write_text(text)
        with pytest.raises(DamagedRunError) as caught:
            load_exported(out)
        message = str(caught.value)
        assert "\n" not in message and f"export` folder: {name}: " in message
        (out / name).write_text(kept)
    (out / "genotype.json").unlink()
    with pytest.raises(DamagedRunError, match=r"genotype\.json: No such file"):
        load_exported(out)


@pytest.mark.parametrize(
    "body",
    ["x = " + DEEP, "body." * 3_000 + "x = 1", "[" + "a." * 3_000 + "b]\nx = 1"],
    ids=["arrays", "dotted-keys", "table-header"],
)
def test_toml_nested_too_deeply_is_one_line(
    body: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "deep.toml"
    config.write_text(f'name = "deep"\n{body}\n')
    assert exit_code(["run", str(config), "--out", str(tmp_path / "run")]) == 2
    assert "malformed TOML: nested too deeply" in one_error_line(capsys)
    assert not (tmp_path / "run").exists()


# --- names from run.json reach the terminal as text --------------------------------------------


def test_runs_and_report_print_names_with_control_sequences_and_markup_as_text(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = Path(shutil.copytree(run_dir, tmp_path / "runs" / "x"))
    with_run_id(run, "[red]x[bold]{y}")  # rich markup: a run id may hold brackets
    edit_json(run / "run.json", lambda info: info.update(status="[bold]ok\x1b]0;title\x07"))
    assert exit_code(["runs", str(tmp_path / "runs")]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\x07" not in out
    assert "[red]x[bold]{y}" in out and "[bold]ok\\x1b]0;title\\x07" in out
    assert exit_code(["report", str(run), "--no-render"]) == 0
    assert "[red]x[bold]{y}" in capsys.readouterr().out
    # A run id with a control sequence (or mathtext's $) is no run id: refused, never shown.
    edit_json(run / "run.json", lambda info: info.update(run_id="x\x1b[2J$\\frac{$"))
    assert exit_code(["report", str(run), "--no-render"]) == 2
    assert "holds a run id that is not one: 'x\\x1b[2J$" in one_error_line(capsys)
    assert exit_code(["runs", str(tmp_path / "runs")]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "unreadable" in out


def test_a_crafted_eval_id_never_names_a_file_outside_the_run(copy: Path) -> None:
    from ariel.recording.resim._replay import replay_recording_path
    from ariel.recording.viewer._view import select_recordings

    _craft(copy, "evaluations", "eval_id", "../../../../outside")
    recordings = copy / "recordings" / "gen-000000"
    recordings.mkdir(parents=True)
    (recordings / "b000000-i000-c000.rrd").write_bytes(b"")  # a run with recordings
    with pytest.raises(DamagedRunError, match=r"has eval_id '(\.\./)+outside', not an id"):
        select_recordings(copy, best=1)  # ariel view RUN --best 1: refused on load
    with pytest.raises(DamagedRunError, match="holds an evaluation id that is not one"):
        replay_recording_path(copy, 0, "../../../../outside")  # where a replay is cached


def test_a_body_that_is_its_own_ancestor_is_one_line(
    copy: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A crafted parent cycle sent the report's lineage walk into a KeyError traceback."""
    best = _best(copy)
    _craft(copy, "bodies", "parent_ids", [best["eval_id"].split("-")[0]])  # its own parent
    assert exit_code(["export", str(copy), "--lineage", str(tmp_path / "l.csv")]) == 2
    assert "born no earlier than it" in one_error_line(capsys)
    assert exit_code(["report", str(copy), "--no-render"]) == 0  # the lineage left out, said
    assert "born no earlier than it" in capsys.readouterr().out
