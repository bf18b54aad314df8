"""Size attacks and limits, refused before anything is built or decoded.

- A table file with more rows than its run's config can make in a generation (a 1 MB file of
  2,000,000 dictionary-encoded rows with a matching manifest made `load_run`, `report` and
  `compare` allocate 4 GB) is refused from its Parquet footer, in one line.
- A campaign of more than `MAX_RUNS` runs (a 1,000 x 1,000 grid, ``seed_count = 10**9``) is
  refused from the file's counts, before any condition or config is made.
- A campaign whose runs' locks (an open file each) do not fit the limit on open files is
  refused in one line before anything is written (it died with a traceback), and the soft
  limit is raised towards the hard one where that is enough. These run in a child process,
  whose limit is lowered, so this process keeps its own.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from _helpers import (
    REPO,
    exit_code,
    one_error_line,
    repo_env,
    tiny_finished_run,
)

from ariel.errors import ConfigError, DamagedRunError
from ariel.recording import load_run
from ariel.recording.store import _table_limits
from ariel.recording.store._manifest import write_manifest
from ariel.recording.store._tables import ROW_MARGIN, TABLES, row_limit
from ariel.recording.store._verify import verify_run
from ariel.runs._campaign_file import MAX_RUNS, campaign_spec

TINY_CAMPAIGN = REPO / "tests" / "data" / "campaign_tiny.toml"


@pytest.fixture(scope="module")
def finished(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished tiny run (2 generations of 2 + 2 bodies, popsize 2, 1 iteration, 0.3 s)."""
    return tiny_finished_run(tmp_path_factory, "sizes", 1)


def _config(run: Path) -> dict:
    return json.loads((run / "run.json").read_text())["config"]


def _grown(run: Path, tmp_path: Path, table: str, rows: int, generation: int = 1) -> Path:
    """A copy of ``run`` whose ``table`` file of ``generation`` holds ``rows`` rows (its first
    row again and again, dictionary encoded: a small file), with a manifest that matches."""
    copy = tmp_path / "copy"
    shutil.copytree(run, copy)
    path = copy / table / f"gen-{generation:06d}.parquet"
    part = pq.read_table(path)
    chunk = part.take(pa.array(np.zeros(min(rows, 100_000), dtype=np.int64)))
    with pq.ParquetWriter(path, part.schema, compression="zstd") as writer:
        for start in range(0, rows, chunk.num_rows):
            writer.write_table(chunk.slice(0, rows - start))
    write_manifest(copy, generation)
    return copy


def test_the_limits_bound_what_a_run_writes(finished: Path) -> None:
    config = _config(finished)
    for table in TABLES:
        for path in sorted((finished / table).glob("gen-*.parquet")):
            generation = int(path.stem.removeprefix("gen-"))
            rows = pq.ParquetFile(path).metadata.num_rows
            assert 0 < rows <= row_limit(config, table, generation), (table, generation, rows)
    # The default experiment: 8 bodies x popsize 8 x 6 iterations a generation.
    assert row_limit({}, "evaluations", 3) == 384
    assert row_limit({}, "bodies", 3) == 8 * 4  # every body made by generation 3, at most
    assert row_limit({}, "trajectories", 0) == 384 * (3 * 10 * 10 + 4)


@pytest.mark.parametrize("table", ["evaluations", "bodies", "trajectories"])
def test_a_table_with_more_rows_than_its_config_makes_is_refused_from_its_footer(
    finished: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, table: str
) -> None:
    most = row_limit(_config(finished), table, 1)
    rows = ROW_MARGIN * most + 1
    copy = _grown(finished, tmp_path, table, rows)
    run = load_run(copy)

    original = pq.read_table

    def decode(*args: object, **kwargs: object) -> pa.Table:
        part = original(*args, **kwargs)
        assert part.num_rows < rows, "the table was decoded before its row count was checked"
        return part

    monkeypatch.setattr(pq, "read_table", decode)
    with pytest.raises(DamagedRunError) as caught:
        getattr(run, table)
    message = str(caught.value)
    assert message.startswith(f"run folder {str(copy)!r} is damaged: "), message
    assert (
        f" is damaged: {table}/gen-000001.parquet has {rows} rows; generation 1 of this run's "
        f"config makes at most {most}: damaged or crafted, not loaded; restore the folder"
    ) in message
    assert "\n" not in message


def test_a_table_within_the_margin_still_loads(finished: Path, tmp_path: Path) -> None:
    most = row_limit(_config(finished), "evaluations", 1)
    copy = _grown(finished, tmp_path, "evaluations", ROW_MARGIN * most)
    assert len(load_run(copy).evaluations) == 4 + ROW_MARGIN * most


def test_report_and_verify_say_so_in_one_line(
    finished: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    copy = _grown(finished, tmp_path, "evaluations", 500_000)
    assert (copy / "evaluations" / "gen-000001.parquet").stat().st_size < 1_000_000  # a small file
    capsys.readouterr()
    assert exit_code(["report", str(copy)]) == 2
    line = one_error_line(capsys)
    assert "evaluations/gen-000001.parquet has 500000 rows; generation 1 of this run's " in line
    assert "makes at most 4: damaged or crafted, not loaded" in line
    assert not (copy / "report").exists()
    result = verify_run(copy)
    assert result.problems == [
        "evaluations/gen-000001.parquet has 500000 rows; generation 1 of this run's config "
        "makes at most 4: damaged or crafted, not loaded"
    ]
    assert exit_code(["verify", str(copy)]) == 1


def test_a_config_value_no_ariel_writes_is_damage_not_a_limit(
    finished: Path, tmp_path: Path
) -> None:
    copy = tmp_path / "copy"
    shutil.copytree(finished, copy)
    info = json.loads((copy / "run.json").read_text())
    info["config"]["brain"]["popsize"] = "8"  # a string: no limit can be worked out
    (copy / "run.json").write_text(json.dumps(info))
    with pytest.raises(DamagedRunError, match=r"is damaged: run\.json has brain\.popsize '8' in"):
        load_run(copy).evaluations  # noqa: B018
    assert any(p.startswith("run.json has brain.popsize '8'") for p in verify_run(copy).problems)


def _rewritten(run: Path, tmp_path: Path, column: str, values: list, **options: object) -> Path:
    """A copy of ``run`` whose generation-1 evaluations file has ``column`` set to ``values``
    (its rows as many), written with ``options``, with a manifest that matches."""
    copy = tmp_path / "copy"
    shutil.copytree(run, copy)
    path = copy / "evaluations" / "gen-000001.parquet"
    part = pq.read_table(path)
    part = part.take(pa.array(np.arange(len(values)) % part.num_rows))
    index = part.schema.get_field_index(column)
    field = part.schema.field(index)
    part = part.set_column(index, field, pa.array(values, field.type))
    pq.write_table(part, path, compression="zstd", **options)  # type: ignore[arg-type]
    write_manifest(copy, 1)
    return copy


def test_a_row_too_large_decoded_is_refused_from_its_footer(
    finished: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture
) -> None:
    """Four rows, as many as the config allows, one holding 20,000,000 doubles: 160 MB decoded
    from a file of a few KB (the probe's had 150,000,000 in 30 KB: 4.6 GB for `report`)."""
    params = [np.zeros(20_000_000), [0.5], [0.5], [0.5]]
    copy = _rewritten(finished, tmp_path, "controller_params", params, use_dictionary=True)
    assert (copy / "evaluations" / "gen-000001.parquet").stat().st_size < 200_000
    original = pq.read_table

    def decode(*args: object, **kwargs: object) -> pa.Table:
        part = original(*args, **kwargs)
        assert part.nbytes < 10_000_000, "the table was decoded before its size was checked"
        return part

    monkeypatch.setattr(pq, "read_table", decode)
    expected = "evaluations/gen-000001.parquet would take 0.16 GB decoded; the 8 rows this run's"
    with pytest.raises(DamagedRunError, match=re.escape(expected)):
        load_run(copy).evaluations  # noqa: B018
    capsys.readouterr()
    assert exit_code(["report", str(copy), "--no-render"]) == 2
    assert expected in one_error_line(capsys)
    monkeypatch.undo()
    (problem,) = verify_run(copy).problems
    assert problem.startswith(expected) and problem.endswith("damaged or crafted, not loaded")


def test_a_value_repeated_through_a_dictionary_counts_once_per_row(
    finished: Path, tmp_path: Path
) -> None:
    """Eight rows (the margin allows them) sharing one 2 MB genotype: one copy in the file's
    dictionary, over 16 MB decoded, more than 8 rows of `ROW_BYTES` may take."""
    big = "x" * (2 << 20)
    copy = _rewritten(finished, tmp_path, "body_genotype", [big] * 8, use_dictionary=True)
    with pytest.raises(DamagedRunError, match=r"would take 1\d\.\d MB decoded; the 8 rows"):
        load_run(copy).evaluations  # noqa: B018
    fits = _rewritten(finished, tmp_path / "fits", "body_genotype", [big] + ["{}"] * 7)
    assert len(load_run(fits).evaluations) == 4 + 8  # 2 MB in one row: within its rows' share


def test_a_table_too_large_for_the_memory_here_is_refused(
    finished: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A config may allow a million bodies (its hash recomputed): the memory free bounds a
    file too, whatever the config allows."""
    monkeypatch.setattr(_table_limits, "machine_memory", lambda: 100_000)
    with pytest.raises(DamagedRunError, match=r"MB decoded, more than 25% of the 0\.1 MB of "):
        load_run(finished).evaluations  # noqa: B018
    assert verify_run(finished).ok  # verify judges the folder, not this machine


def test_joint_signals_read_only_their_columns(finished: Path) -> None:
    run = load_run(finished)
    eval_id = str(run.evaluations["eval_id"].iloc[0])
    signals = run.joint_signals(eval_id)
    frames = run.trajectories[run.trajectories["eval_id"] == eval_id]
    assert len(signals) == len(frames) > 0
    assert list(signals.index) == sorted(frames["t"])


# --------------------------------------------------------------------------------------------
# Campaigns: how many runs
# --------------------------------------------------------------------------------------------

_BASE = {"generations": 1}


def test_a_campaign_of_a_billion_seeds_or_a_million_point_grid_is_refused_unbuilt() -> None:
    with pytest.raises(ConfigError) as caught:
        campaign_spec({"base": _BASE, "seed_count": 10**9})
    assert str(caught.value) == (
        f"campaign: 1 condition(s) x 1000000000 seed(s) = 1000000000 runs; at most {MAX_RUNS} "
        "runs a campaign: fewer grid values or seeds, or split it into smaller campaigns"
    )
    grid = {"brain.popsize": list(range(2, 1002)), "brain.iterations": list(range(1, 1001))}
    with pytest.raises(ConfigError, match=r"1000000 condition\(s\) x 2 seed\(s\) = 2000000 runs"):
        campaign_spec({"base": _BASE, "seeds": [1, 2], "grid": grid})
    named = [{"name": "a"}, {"name": "b"}]
    with pytest.raises(ConfigError, match=r"= 10002 runs; at most 10000 runs"):
        campaign_spec({"base": _BASE, "seed_count": 5001, "condition": named})
    with pytest.raises(ConfigError, match=r"4 condition\(s\) x 2 seed\(s\) = 8 runs; at most 7"):
        campaign_spec(
            {"base": _BASE, "seeds": [1, 2], "condition": named, "grid": {"brain.popsize": [2, 4]}},
            max_runs=7,
        )
    assert len(campaign_spec({"base": _BASE, "seeds": [1, 2], "condition": named}).configs) == 4


def test_the_campaign_command_refuses_too_many_runs_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    file = tmp_path / "huge.toml"
    file.write_text(TINY_CAMPAIGN.read_text().replace("seeds = [1, 2]", "seed_count = 1000000000"))
    capsys.readouterr()
    assert exit_code(["campaign", "run", str(file), "--out", str(tmp_path / "out")]) == 2
    assert "= 2000000000 runs; at most 10000 runs" in one_error_line(capsys)
    assert not (tmp_path / "out").exists()


# --------------------------------------------------------------------------------------------
# Campaigns: one lock (an open file) per run
# --------------------------------------------------------------------------------------------


def _under_limit(code: str, soft: int, hard: int | None = None) -> subprocess.CompletedProcess:
    """``code`` in a child process whose limit on open files is ``soft`` (hard: ``hard``, else
    the same); its exit code, stdout and stderr."""
    limit = f"({soft}, {hard if hard is not None else soft})"
    script = "import resource, sys\n"
    script += f"resource.setrlimit(resource.RLIMIT_NOFILE, {limit})\n"
    script += textwrap.dedent(code)
    return subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        env=repo_env(),
        cwd=REPO,
        timeout=300,
    )


def _many_seeds(tmp_path: Path) -> Path:
    """The tiny campaign on seeds 1..59: 118 runs, more than 64 open files allow."""
    file = tmp_path / "many.toml"
    seeds = f"seeds = {list(range(1, 60))}"
    file.write_text(TINY_CAMPAIGN.read_text().replace("seeds = [1, 2]", seeds))
    return file


def test_a_campaign_that_needs_more_open_files_than_allowed_is_refused_in_one_line(
    tmp_path: Path,
) -> None:
    out = tmp_path / "out"
    done = _under_limit(
        f"""
        from ariel.cli import main
        sys.exit(main(["campaign", "run", {str(_many_seeds(tmp_path))!r}, "--out", {str(out)!r}]))
        """,
        64,
    )
    assert done.returncode == 2, done.stderr
    lines = done.stderr.splitlines()
    assert len(lines) == 1, done.stderr
    assert re.match(r"ariel: error: this campaign needs about \d+ open files \(118 runs", lines[0])
    assert "the limit is 64 (ulimit -n): raise it with ulimit -n" in lines[0]
    assert not out.exists()  # nothing written


def test_a_campaign_resume_that_needs_more_open_files_is_refused_before_it_writes(
    tmp_path: Path,
) -> None:
    """campaign.json of 118 runs killed before their folders were made (resume makes them)."""
    from ariel.recording.store._campaign import run_path, write_campaign_info

    spec = campaign_spec(json.loads(json.dumps(_toml(_many_seeds(tmp_path)))), beside=REPO)
    folder = tmp_path / "campaign"
    folder.mkdir()
    runs = [
        {
            "condition": condition,
            "seed": seed,
            "path": run_path(condition, seed),
            "run_id": f"many-{condition}-s{seed}",
            "config": config.to_plain(),
        }
        for (condition, seed), config in spec.configs.items()
    ]
    conditions = [
        {"name": c.name, "set": c.set, "description": "", "seeds": spec.seeds_of(c.name)}
        for c in spec.conditions
    ]
    info = {
        "campaign_id": "many",
        "name": "many",
        "seeds": spec.seeds,
        "seeding": "shared",
        "conditions": conditions,
        "runs": runs,
        "executor": {"kind": "serial", "workers": None, "address": None},
        "status": "interrupted",
    }
    write_campaign_info(folder, info)
    done = _under_limit(
        f"""
        from ariel.cli import main
        sys.exit(main(["campaign", "resume", {str(folder)!r}]))
        """,
        64,
    )
    assert done.returncode == 2, done.stderr
    lines = done.stderr.splitlines()
    assert len(lines) == 1, done.stderr
    assert re.search(r"this campaign needs about \d+ open files \(118 runs at once", lines[0])
    assert not (folder / "runs").exists()  # no run folder made


def _toml(path: Path) -> dict:
    import tomllib

    return tomllib.loads(path.read_text())


def test_the_soft_limit_is_raised_where_the_hard_one_allows() -> None:
    done = _under_limit(
        """
        from ariel.recording.store._lock import ensure_open_files
        ensure_open_files(118, 2)
        print(resource.getrlimit(resource.RLIMIT_NOFILE)[0])
        """,
        64,
        1024,
    )
    assert done.returncode == 0, done.stderr
    assert int(done.stdout) >= 118 + 64 + 2 * 8


@pytest.mark.parametrize(
    ("soft", "extra", "said"),
    [
        (
            100,
            ["--executor", "local", "--workers", "8"],
            "a local pool of 8 workers needs "
            "about 128 open files; the limit is 100 (ulimit -n): use at most 4 workers",
        ),
        (
            20,
            [],
            "this process may open only 20 files at once (ulimit -n); ariel needs at least 64",
        ),
    ],
    ids=["local-pool", "any-command"],
)
def test_too_few_open_files_for_a_run_is_one_line_before_anything_is_written(
    tmp_path: Path, soft: int, extra: list[str], said: str
) -> None:
    """Under ``ulimit -n 20`` the local pool's fork server printed its traceback before the
    line, and Rerun's import aborts the process (a 170-line panic) below about 26."""
    out = tmp_path / "out"
    argv = ["run", "--out", str(out), "--quiet", *extra]
    done = _under_limit(f"from ariel.cli import main\nsys.exit(main({argv!r}))\n", soft)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and said in lines[0], done.stderr
    assert not out.exists()


def test_every_table_has_a_row_size() -> None:
    """`ROW_BYTES` names the tables the limits apply to (`_table_of`): all of them."""
    from ariel.recording.store._table_limits import ROW_BYTES
    from ariel.recording.store._tables import TABLES

    assert set(ROW_BYTES) == set(TABLES)
