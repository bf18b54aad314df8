"""`ariel export RUN EVAL_ID|best DIR`: MJCF that MuJoCo loads, genotype and controller JSON,
and a replay script on the tutorial API that runs and follows the recorded path."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
from _helpers import ariel_run, exit_code, one_error_line, repo_env, tiny_run_toml

from ariel.recording import load_run


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("export")
    config = folder / "tiny.toml"
    config.write_text(tiny_run_toml("export", 7))
    ariel_run(config, folder / "run")
    return folder / "run"


def test_export_writes_mjcf_json_and_a_replay_script_that_follows_the_run(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "best"
    assert exit_code(["export", str(run_dir), "best", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == [
        "body.xml",
        "controller.json",
        "genotype.json",
        "replay.py",
    ]
    run = load_run(run_dir)
    brain = json.loads((out / "controller.json").read_text())
    row = run.evaluations.set_index("eval_id").loc[brain["eval_id"]]
    ok = run.evaluations[np.isfinite(run.evaluations["fitness"])]
    assert row["fitness"] == ok["fitness"].max()  # the best one
    assert brain["params"] == list(row["controller_params"])  # exact
    genotype = json.loads((out / "genotype.json").read_text())
    assert genotype["genotype"] == json.loads(row["body_genotype"])
    assert genotype["body_encoder"] == row["body_encoder"]

    model = mujoco.MjModel.from_xml_path(str(out / "body.xml"))  # what MuJoCo's viewer loads
    assert model.nu == row["n_joints"]

    done = subprocess.run(
        [sys.executable, str(out / "replay.py")],
        cwd=tmp_path,
        env=repo_env(),
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    final = json.loads(done.stdout.strip().removeprefix("core at "))
    frames = run.trajectories[run.trajectories["eval_id"] == brain["eval_id"]].sort_values("t")
    start = frames[["core_x", "core_y", "core_z"]].to_numpy()[0]
    end = frames[["core_x", "core_y", "core_z"]].to_numpy()[-1]
    np.testing.assert_array_equal(final, end)  # the tutorial path is the engine's
    assert np.linalg.norm(end - start) > 1e-3  # it moved


def test_export_of_an_unknown_evaluation_is_one_line(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert exit_code(["export", str(run_dir), "b999999-i000-c000", str(tmp_path / "x")]) == 2
    assert "no evaluation 'b999999-i000-c000'" in one_error_line(capsys)
    assert not (tmp_path / "x").exists()


def test_export_into_a_folder_that_is_not_empty_is_one_line(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "keep.txt").write_text("mine")
    assert exit_code(["export", str(run_dir), "best", str(tmp_path)]) == 2
    assert "is not an empty folder" in one_error_line(capsys)
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]
