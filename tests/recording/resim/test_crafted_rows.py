"""Rows a hostile probe crafted (a table changed, its manifest written again so that `ariel
verify` passes), and raced exports: each refused or reported in one line, never a traceback,
never a half-written folder.

1. ids: ASCII digits only, not too many (``b٠٠٠٠٠٣``, a body number of 4,301 digits);
2. export: plugin names and seed from the run's config / checked; replay.py's errors one
   escaped line; an export is all or nothing (raced, interrupted);
3. a robot graph larger than the run's encoder makes is refused before it is built;
4. a genotype that does not build is worded as damage, and the report leaves out only its
   picture.

One tiny run for the module; each test crafts a copy.
"""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from _helpers import (
    ariel_run,
    exit_code,
    one_error_line,
    run_replay_script,
    tiny_run_toml,
)

from ariel.errors import DamagedRunError
from ariel.recording import load_run
from ariel.recording.resim import _export
from ariel.recording.resim._rebuild import replay_task
from ariel.recording.store._ids import BODY_ID, EVAL_ID, check_body_id, check_eval_id
from ariel.recording.store._manifest import write_manifest

ARABIC = "b\u0660\u0660\u0660\u0660\u0660\u0669"  # b٠٠٠٠٠٩: int() reads it as 9
HOSTILE = '[/bold]\x1b[2J\u202eevil\n__import__("os").system("touch pwned")'


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("crafted")
    config = folder / "tiny.toml"
    config.write_text(tiny_run_toml("crafted", 1))  # body.options.number_of_modules = 10
    ariel_run(config, folder / "run")
    return folder / "run"


def _best(run: Path) -> dict[str, Any]:
    evaluations = load_run(run).evaluations
    return evaluations.sort_values("fitness").iloc[-1].to_dict()


def _craft(
    run_dir: Path, copy: Path, table: str, column: str, value: object, pick: Callable[..., bool]
) -> Path:
    """A copy of the run whose ``table`` holds ``value`` in ``column`` of the rows ``pick``
    takes (a row as a dict), every generation's file, its manifest written again."""
    shutil.copytree(run_dir, copy)
    for path in sorted((copy / table).glob("gen-*.parquet")):
        rows = pq.read_table(path)
        cells = rows.column(column).to_pylist()
        cells = [value if pick(row) else cell for row, cell in zip(rows.to_pylist(), cells)]
        index = rows.schema.get_field_index(column)
        field = rows.schema.field(index)
        pq.write_table(rows.set_column(index, field, pa.array(cells, field.type)), path)
        write_manifest(copy, int(path.stem.removeprefix("gen-")))
    # as a crafter leaves it: its manifests agree; an id's shape verify checks itself
    shapes = {"eval_id": EVAL_ID, "body_id": BODY_ID}
    shaped = column not in shapes or bool(shapes[column].fullmatch(str(value)))
    assert exit_code(["verify", str(copy)]) == (0 if shaped else 1)
    return copy


def _of_body(body_id: str) -> Callable[[dict[str, Any]], bool]:
    return lambda row: row["body_id"] == body_id


# --- 1: ids --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "value",
    [ARABIC, "b" + "1" * 13, "b" + "1" * 4301, "b00001", "b000001\n", "b000001 "],
)
def test_a_body_id_is_6_to_12_ascii_digits(value: str) -> None:
    assert BODY_ID.fullmatch("b000001") and BODY_ID.fullmatch("b" + "9" * 12)
    assert check_body_id("b000012", "run") == "b000012"
    assert not BODY_ID.fullmatch(value)
    with pytest.raises(DamagedRunError, match="holds a body id that is not one"):
        check_body_id(value, "run")
    with pytest.raises(DamagedRunError, match="holds an evaluation id that is not one"):
        check_eval_id(f"{value}-i000-c000", "run")
    assert EVAL_ID.fullmatch("b000012-i003-c005")
    assert not EVAL_ID.fullmatch("b000012-i\u0663\u0663\u0663-c005")
    assert not EVAL_ID.fullmatch("b000012-i003-c" + "5" * 13)


@pytest.mark.parametrize("body_id", [ARABIC, "b" + "1" * 4301], ids=["arabic", "4301-digits"])
def test_a_crafted_body_id_is_refused_by_lineage_in_one_line(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], body_id: str
) -> None:
    copy = _craft(run_dir, tmp_path / "run", "bodies", "body_id", body_id, _of_body("b000002"))
    with pytest.raises(DamagedRunError, match=r"has body_id .*, not an id: changed by hand"):
        load_run(copy).lineage()
    capsys.readouterr()
    assert exit_code(["export", str(copy), "--lineage", str(tmp_path / "l.csv")]) == 2
    line = one_error_line(capsys)
    assert "not an id: changed by hand or crafted" in line and len(line) < 400
    assert not (tmp_path / "l.csv").exists()


def test_an_evaluation_of_another_body_is_refused(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    best = _best(run_dir)
    copy = _craft(
        run_dir, tmp_path / "run", "evaluations", "body_id", "b000099", _of_body(best["body_id"])
    )
    capsys.readouterr()
    assert exit_code(["export", str(copy), "best", str(tmp_path / "x")]) == 2
    assert "its body_id 'b000099' is not its evaluation's" in one_error_line(capsys)


def test_a_huge_body_id_in_the_gallery_is_one_line(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    best = _best(run_dir)["body_id"]
    huge = "b" + "1" * 1_000_000
    copy = _craft(run_dir, tmp_path / "run", "bodies", "body_id", huge, _of_body(best))
    capsys.readouterr()
    assert exit_code(["gallery", str(copy)]) == 2
    line = one_error_line(capsys)
    assert "not an id: changed by hand or crafted" in line and len(line) < 400


def test_a_label_a_million_characters_long_is_cut_at_once() -> None:
    from PIL import Image, ImageDraw

    from ariel.recording.analysis._gallery_sheet import _fitted, _font

    draw = ImageDraw.Draw(Image.new("RGB", (10, 10)))
    start = time.perf_counter()
    cut = _fitted(draw, "b" + "1" * 1_000_000, _font(13), 200)
    assert time.perf_counter() - start < 1.0
    assert cut.startswith("b1") and "…" in cut and draw.textlength(cut, font=_font(13)) <= 200
    assert _fitted(draw, "b000012", _font(13), 200) == "b000012"


# --- 2: export -----------------------------------------------------------------------------


def test_a_row_naming_another_encoder_is_refused_and_never_exported(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    best = _best(run_dir)
    copy = _craft(
        run_dir, tmp_path / "run", "evaluations", "body_encoder", HOSTILE, _of_body(best["body_id"])
    )
    capsys.readouterr()
    for argv in (["export", str(copy), "best", str(tmp_path / "x")], ["replay", str(copy), "best"]):
        assert exit_code(argv) == 2, argv
        line = one_error_line(capsys)
        assert "its body_encoder '[/bold]\\x1b[2J\\u202eevil\\n" in line, line
        assert "is not the run's 'nde' (run.json's body.encoder)" in line
        assert "the evaluations table was changed" in line and "\x1b" not in line
    assert not (tmp_path / "x").exists() and not (tmp_path / "pwned").exists()


def test_export_takes_the_plugin_names_from_the_run_s_config(run_dir: Path, tmp_path: Path) -> None:
    out = _export.export(run_dir, "best", tmp_path / "x")
    config = load_run(run_dir).config
    assert json.loads((out / "genotype.json").read_text())["body_encoder"] == "nde"
    brain = json.loads((out / "controller.json").read_text())
    assert brain["controller"] == config["brain"]["controller"]
    assert (brain["world"], brain["fitness_fn"]) == (
        config["world"]["name"],
        config["task"]["fitness"],
    )


def test_replay_py_prints_an_error_as_one_escaped_line(run_dir: Path, tmp_path: Path) -> None:
    out = _export.export(run_dir, "best", tmp_path / "x")
    genotype = json.loads((out / "genotype.json").read_text())
    genotype["body_encoder"] = HOSTILE  # an exported folder edited on its way
    (out / "genotype.json").write_text(json.dumps(genotype))
    done = run_replay_script(out, tmp_path)
    assert done.returncode == 1 and done.stdout == ""
    (line,) = done.stderr.splitlines()
    assert line.startswith("replay.py: error: UnknownPluginError: unknown body encoder")
    assert "\\x1b[2J\\u202eevil\\n__import__" in line and "Traceback" not in line
    assert line.isascii() and line.isprintable() and not (tmp_path / "pwned").exists()


def test_a_negative_seed_is_refused_naming_the_table(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    best = _best(run_dir)
    copy = _craft(run_dir, tmp_path / "run", "evaluations", "seed", -5, _of_body(best["body_id"]))
    capsys.readouterr()
    for argv in (["export", str(copy), "best", str(tmp_path / "x")], ["replay", str(copy), "best"]):
        assert exit_code(argv) == 2, argv
        line = one_error_line(capsys)
        assert f"evaluation {best['eval_id']!r} of run {str(copy)!r}: its seed -5 is not a " in line
        assert "non-negative integer; the evaluations table was changed" in line
    assert not (tmp_path / "x").exists()


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def test_two_exports_into_one_folder_at_once_leave_one_whole_export(
    run_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The second export finishes while the first is writing: the first, finding the folder
    made, says so; the folder holds the second's files only."""
    import ariel.recording.store as store

    out, write, seen = tmp_path / "x", store.atomic_write, []

    def racing(path: Path, *args: Any, **kwargs: Any) -> None:
        seen.append(path)
        if len(seen) == 1:
            monkeypatch.setattr(store, "atomic_write", write)
            _export.export(run_dir, "best", out)  # the other export, whole
        write(path, *args, **kwargs)

    monkeypatch.setattr(store, "atomic_write", racing)
    with pytest.raises(_export.ExportError, match=r"was made meanwhile .* nothing was exported"):
        _export.export(run_dir, "b000000-i000-c000", out)
    first = seen[0].parent  # where the first export wrote: hidden, beside out
    assert first.parent == tmp_path and first.name.startswith(".x.") and first.suffix == ".tmp"
    assert json.loads((out / "controller.json").read_text())["eval_id"] == _best(run_dir)["eval_id"]
    assert sorted(p.name for p in out.iterdir()) == sorted(_export.FILES)
    assert _leftovers(tmp_path) == []


@pytest.mark.parametrize("stop", [KeyboardInterrupt, OSError(28, "No space left on device")])
def test_an_export_stopped_between_files_leaves_nothing_and_a_retry_works(
    run_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, stop: BaseException
) -> None:
    import ariel.recording.store as store

    write, written = store.atomic_write, []

    def stopped_after_one(path: Path, *args: Any, **kwargs: Any) -> None:
        if written:
            raise stop
        write(path, *args, **kwargs)
        written.append(path)

    monkeypatch.setattr(store, "atomic_write", stopped_after_one)
    out = tmp_path / "new" / "x"
    with pytest.raises(KeyboardInterrupt if stop is KeyboardInterrupt else _export.ExportError):
        _export.export(run_dir, "best", out)
    assert written and not (tmp_path / "new").exists()  # the folder made on the way too
    monkeypatch.setattr(store, "atomic_write", write)
    assert sorted(p.name for p in _export.export(run_dir, "best", out).iterdir()) == sorted(
        _export.FILES
    )
    assert _leftovers(out.parent) == []


def test_an_export_into_an_empty_folder_fills_it_but_not_the_one_it_runs_in(
    run_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "empty").mkdir()
    assert len(list(_export.export(run_dir, "best", tmp_path / "empty").iterdir())) == 4
    (tmp_path / "here").mkdir()
    monkeypatch.chdir(tmp_path / "here")
    with pytest.raises(_export.ExportError, match="is the folder this command runs in"):
        _export.export(run_dir, "best", ".")
    assert list((tmp_path / "here").iterdir()) == []


# --- 3: a body larger than the run's encoder makes ----------------------------------------


def _chain(modules: int) -> str:
    """A robot graph: the core and a chain of ``modules - 1`` bricks."""
    nodes = [{"id": 0, "rotation": "DEG_0", "type": "CORE"}]
    nodes += [{"id": i, "rotation": "DEG_0", "type": "BRICK"} for i in range(1, modules)]
    edges = [{"face": "FRONT", "source": i - 1, "target": i} for i in range(1, modules)]
    return json.dumps({"directed": True, "edges": edges, "graph": {}, "nodes": nodes})


@pytest.mark.parametrize("modules", [11, 20_000])
def test_a_graph_larger_than_the_encoder_makes_is_refused_before_it_is_built(
    run_dir: Path, tmp_path: Path, modules: int
) -> None:
    best = _best(run_dir)
    copy = _craft(
        run_dir, tmp_path / "run", "bodies", "graph", _chain(modules), _of_body(best["body_id"])
    )
    run = load_run(copy)
    graph = run.bodies.loc[run.bodies["body_id"] == best["body_id"], "graph"].iloc[-1]
    start = time.perf_counter()
    with pytest.raises(DamagedRunError) as caught:
        replay_task(run, best, graph=graph)
    assert time.perf_counter() - start < 2.0
    assert f"its body has {modules:,} modules, more than the 10 its body encoder 'nde' " in str(
        caught.value
    )
    assert "(number_of_modules = 10); the bodies table was changed" in str(caught.value)
    replay_task(load_run(run_dir), best, graph=_chain(10))  # as many as it makes: built


def test_a_genotype_longer_than_the_encoder_s_is_refused(run_dir: Path, tmp_path: Path) -> None:
    best = _best(run_dir)
    genotype = json.dumps([[0.5] * 64] * 3 + [[0.5] * 100_000])
    copy = _craft(
        run_dir,
        tmp_path / "run",
        "evaluations",
        "body_genotype",
        genotype,
        _of_body(best["body_id"]),
    )
    with pytest.raises(
        DamagedRunError, match="holds more than the 192 genes of body encoder 'nde'"
    ):
        replay_task(load_run(copy), _best(copy))


# --- 4: a genotype that does not build -----------------------------------------------------


def test_an_unbuildable_genotype_is_damage_and_the_report_leaves_out_its_picture(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    best = _best(run_dir)
    copy = _craft(
        run_dir,
        tmp_path / "run",
        "evaluations",
        "body_genotype",
        '[[1e308, "x"]]',
        _of_body(best["body_id"]),
    )
    with pytest.raises(DamagedRunError) as caught:
        replay_task(load_run(copy), _best(copy))
    expected = (
        f"evaluation {best['eval_id']!r} of run {str(copy)!r}: its body {best['body_id']!r} "
        "could not be built from the stored genotype (body encoder 'nde': this genotype cannot "
        "be built: ValueError: genotype must have exactly 3 chromosomes"
    )
    assert str(caught.value).startswith(expected)
    assert str(caught.value).endswith("; the evaluations table was changed or damaged")
    capsys.readouterr()
    assert exit_code(["report", str(copy)]) == 0
    captured = capsys.readouterr()
    assert captured.err == "" and f"best_body.png: left out ({expected}" in captured.out
