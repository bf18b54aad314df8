"""``body.genotype`` as a file: a fixed NDE body from ``.json`` or ``.npy``, brain-only.

The run stores the genotype itself (run.json's config, the tables), never the file's path,
so a copied run folder resumes and replays without the file.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from ariel.evolution import ConfigError, load_config, run_experiment
from ariel.evolution._config import config_hash
from ariel.recording import load_run, replay

OPTIONS = {"number_of_modules": 10, "genotype_size": 16}
TOML = """
name = "fixednde"
seed = 7
generations = 2

[body]
genotype = "bodies/chosen.json"
options = { number_of_modules = 10, genotype_size = 16 }

[brain]
popsize = 3
iterations = 2

[task]
duration = 0.3

[record]
rerun = false

[executor]
kind = "serial"
"""


def _genotype() -> np.ndarray:
    """A genotype as the nde encoder makes them (float32), one that builds a jointed body."""
    from ariel.ec.genotypes.nde.encoder import NDEEncoder

    return NDEEncoder(**OPTIONS).random_genotype(np.random.default_rng(3))


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The same fixed body from a JSON file (named in a TOML file) and from a .npy file."""
    root = tmp_path_factory.mktemp("fixed")
    experiment = root / "experiment"
    (experiment / "bodies").mkdir(parents=True)
    genotype = _genotype()
    (experiment / "bodies" / "chosen.json").write_text(json.dumps(genotype.tolist()))
    (experiment / "fixed.toml").write_text(TOML)
    np.save(root / "chosen.npy", genotype)
    from_json = run_experiment(experiment / "fixed.toml", out=root / "from-json").run_dir
    from_npy = run_experiment(
        experiment / "fixed.toml",
        out=root / "from-npy",
        overrides=[f"body.genotype={json.dumps(str(root / 'chosen.npy'))}"],
    ).run_dir
    return {"root": root, "json": from_json, "npy": from_npy}


def test_a_fixed_nde_genotype_makes_the_run_brain_only(runs: dict[str, Path]) -> None:
    run = load_run(runs["json"])
    assert set(run.bodies["body_id"]) == {"b000000"}
    assert len(run.evaluations) == 2 * 3 * 2  # generations x popsize x iterations
    # One CMA-ES run goes on across generations: iterations 0-1, then 2-3.
    assert sorted(set(run.evaluations["iteration"])) == [0, 1, 2, 3]
    stored = json.loads(run.bodies["body_genotype"].iloc[0])
    assert np.array_equal(np.array(stored, dtype=np.float32), _genotype())
    assert run.evaluations["n_joints"].iloc[0] > 0


def test_the_run_stores_the_genotype_not_the_path(runs: dict[str, Path]) -> None:
    info = json.loads((runs["json"] / "run.json").read_text())
    assert np.array_equal(np.array(info["config"]["body"]["genotype"], np.float32), _genotype())
    for run_dir in (runs["json"], runs["npy"]):
        text = (run_dir / "run.json").read_text()
        assert "chosen" not in text and str(runs["root"]) not in text
    # JSON or .npy: the same genotype is the same experiment, with the same records.
    json_run, npy_run = load_run(runs["json"]), load_run(runs["npy"])
    assert json_run.info["config_hash"] == npy_run.info["config_hash"]
    columns = ["eval_id", "fitness", "controller_params", "body_genotype"]
    assert json_run.evaluations[columns].equals(npy_run.evaluations[columns])


def test_a_copied_run_replays_and_resumes_without_the_file(
    runs: dict[str, Path], tmp_path: Path
) -> None:
    from ariel.evolution import resume_experiment

    copy = tmp_path / "copy"
    shutil.copytree(runs["json"], copy)
    info = json.loads((copy / "run.json").read_text())
    info["status"] = "interrupted"  # as if stopped after its last generation
    (copy / "run.json").write_text(json.dumps(info))
    files = [runs["root"] / "experiment" / "bodies" / "chosen.json", runs["root"] / "chosen.npy"]
    for path in files:  # the genotype files are gone
        path.rename(tmp_path / path.name)
    try:
        assert replay(copy, "best").identical
        assert resume_experiment(copy).status == "finished"  # the stored genotype, re-checked
    finally:
        for path in files:
            (tmp_path / path.name).rename(path)
    # An edited stored genotype is an edited config.
    info["config"]["body"]["genotype"][0][0] += 0.25
    (copy / "run.json").write_text(json.dumps(info))
    with pytest.raises(ValueError, match="config was edited") as refused:
        resume_experiment(copy)
    assert "\n" not in str(refused.value)


def test_a_toml_genotype_path_is_relative_to_the_toml_and_set_to_the_working_dir(
    runs: dict[str, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    experiment = runs["root"] / "experiment"
    monkeypatch.chdir(runs["root"])  # not the TOML's folder
    config = load_config(experiment / "fixed.toml")
    assert Path(config.body.genotype) == experiment / "bodies" / "chosen.json"
    relative = load_config(experiment / "fixed.toml", ["body.genotype='chosen.npy'"])
    assert relative.body.genotype == "chosen.npy"  # --set: relative to where ariel runs


def test_an_inline_genotype_is_checked_too_and_equals_the_file(runs: dict[str, Path]) -> None:
    from ariel.runs._experiment import _read_genotype_file, resolve_plugins as _resolve

    genotype = _genotype()
    inline = load_config(
        {**_plain_toml(), "body": {"genotype": genotype.tolist(), "options": OPTIONS}}
    )
    from_file = load_config(runs["root"] / "experiment" / "fixed.toml")
    from_file = _read_genotype_file(from_file, _resolve(from_file).encoder)
    assert config_hash(inline) == config_hash(from_file)
    bad = genotype.tolist()
    bad[2] = bad[2][:-1]
    with pytest.raises(ConfigError, match=r"^body.genotype: not an array of numbers"):
        _resolve(load_config({**_plain_toml(), "body": {"genotype": bad, "options": OPTIONS}}))


def _plain_toml() -> dict:
    import tomllib

    data = tomllib.loads(TOML)
    data.pop("body")
    return data


def test_a_body_of_one_run_becomes_the_fixed_body_of_the_next(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The recipe of docs/evolution.md: the ``body_genotype`` JSON of a run's best body."""
    import tomllib

    config = tomllib.loads(TOML)
    config["body"] = {"options": OPTIONS, "population": 2, "offspring": 2}
    config["generations"] = 1
    first = load_run(run_experiment(config, out=tmp_path / "first").run_dir)
    bodies = first.bodies
    best = bodies.loc[bodies["fitness"].idxmax()]
    (tmp_path / "best.json").write_text(best["body_genotype"])
    monkeypatch.chdir(tmp_path)
    config["body"] = {"options": OPTIONS, "genotype": "best.json"}
    second = load_run(run_experiment(config, out=tmp_path / "second").run_dir)
    assert second.bodies["graph"].tolist() == [best["graph"]]
    assert second.bodies["body_genotype"].tolist() == [best["body_genotype"]]


def test_a_leading_tilde_in_toml_paths_is_the_home_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--out ~/x`` is the home folder, but ``genotype = "~/g.json"`` in a TOML file and a
    campaign's ``base = "~/base.toml"`` were a folder named ``~`` beside the file (probe G4)."""
    from ariel.runs import load_campaign_file

    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    (tmp_path / "home").mkdir()
    (tmp_path / "home" / "g.json").write_text(json.dumps(_genotype().tolist()))
    (tmp_path / "elsewhere").mkdir()
    toml = TOML.replace('"bodies/chosen.json"', '"~/g.json"')
    (tmp_path / "elsewhere" / "fixed.toml").write_text(toml)
    from ariel.evolution._genotype import read_genotype_file

    config = load_config(tmp_path / "elsewhere" / "fixed.toml")
    assert config.body.genotype == str(tmp_path / "home" / "g.json")
    read = read_genotype_file("~/g.json")  # as --set body.genotype="~/g.json" is read
    assert np.array_equal(np.array(read, dtype=np.float32), _genotype())
    (tmp_path / "home" / "base.toml").write_text(toml.replace('"~/g.json"', '"g.json"'))
    (tmp_path / "elsewhere" / "c.toml").write_text('base = "~/base.toml"\nseeds = [1]\n')
    spec = load_campaign_file(tmp_path / "elsewhere" / "c.toml")
    assert next(iter(spec.configs.values())).name == "fixednde"
