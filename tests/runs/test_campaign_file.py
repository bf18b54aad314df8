"""Campaign files: conditions, grids and seeds become one config per run; bad input is one line
on stderr, exit code 2, and nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest
from _helpers import REPO, exit_code, one_error_line

from ariel.evolution import ConfigError
from ariel.runs._campaign_file import campaign_spec, load_campaign_file

BASE = {
    "name": "t",
    "generations": 1,
    "body": {"population": 2, "offspring": 2},
    "brain": {"popsize": 2, "iterations": 1},
    "executor": {"kind": "serial"},
}


def test_a_grid_crossed_with_named_conditions_names_every_point_from_its_values() -> None:
    spec = campaign_spec(
        {
            "base": BASE,
            "seed_count": 2,
            "set": {"task.duration": 0.5},
            "condition": [{"name": "a", "set": {"brain.inherit": True}}, {"name": "b"}],
            "grid": {"brain.popsize": [4, 6], "world.name": ["flat", "rugged"]},
        }
    )
    names = [c.name for c in spec.conditions]
    assert names[:2] == ["a_popsize-4_name-flat", "a_popsize-4_name-rugged"] and len(names) == 8
    assert spec.seeds == [1, 2] and len(spec.configs) == 16
    config = spec.configs[("a_popsize-6_name-rugged", 2)]
    assert (config.brain.popsize, config.world.name, config.brain.inherit) == (6, "rugged", True)
    assert config.seed == 2 and config.task.duration == 0.5  # campaign-wide `set` applied
    assert spec.configs[("b_popsize-4_name-flat", 1)].brain.inherit is False


def test_the_shipped_campaigns_are_valid() -> None:
    for name, conditions in (
        ("inheritance", ["fresh", "inherit"]),
        ("ga_vs_map_elites", ["ga", "map_elites", "novelty"]),
    ):
        spec = load_campaign_file(REPO / "experiments" / "campaigns" / f"{name}.toml")
        assert [c.name for c in spec.conditions] == conditions and len(spec.seeds) == 5
    # The study's two stages: one campaign, seeds 1..10 and 11..20 (pooled by ariel compare).
    first, second = (
        load_campaign_file(REPO / "experiments" / "campaigns" / f"{name}.toml")
        for name in ("default_vs_baselines", "default_vs_baselines_more_seeds")
    )
    assert first.name == second.name and first.conditions == second.conditions
    assert first.seeds == list(range(1, 11)) and second.seeds == list(range(11, 21))


_GOOD = 'base = {{ name = "t", executor = {{ kind = "serial" }} }}\nseeds = [1]\n{rest}'
CASES = {
    "unknown key in a condition's set": (
        '[[condition]]\nname = "x"\nset = { "brain.inheret" = true }\n',
        "condition 'x': 'brain.inheret': no such key; keys under brain:",
    ),
    "bad value in a condition": (
        '[[condition]]\nname = "x"\nset = { "brain.popsize" = 0 }\n',
        "condition 'x': brain.popsize: must be greater than or equal to 2",
    ),
    "bad value in the base, not the condition's": (  # it blamed condition 'x'
        '[[condition]]\nname = "x"\nset = { "brain.popsize" = 4 }\n[set]\n"brain.iterations" = 0\n',
        "base (with set and --set): brain.iterations: must be greater than or equal to 1",
    ),
    "a condition whose value breaks a rule across keys": (  # it blamed the base
        '[set]\n"body.survivors" = "generational"\n"body.population" = 4\n"body.offspring" = 4\n'
        '[[condition]]\nname = "x"\nset = { "body.offspring" = 2 }\n',
        "condition 'x': body: generational survival needs offspring >= population",
    ),
    "unknown key of a condition": (
        '[[condition]]\nname = "x"\nsett = {}\n',
        "unknown key 'condition.0.sett'; allowed: description, name, set",
    ),
    "duplicate condition names": (
        '[[condition]]\nname = "x"\n[[condition]]\nname = "x"\n',
        "condition: duplicate name 'x'",
    ),
    "names that differ in case only": (  # one folder on macOS and Windows
        '[[condition]]\nname = "Sigma"\n[[condition]]\nname = "sigma"\n',
        "condition: 'sigma' and 'Sigma' differ in case only",
    ),
    "duplicate names with capitals": (
        '[[condition]]\nname = "X"\n[[condition]]\nname = "X"\n',
        "condition: duplicate name 'X'",
    ),
    "grid values that make one name": (
        '[grid]\n"description" = ["a!b", "a?b"]\n',
        "condition: duplicate name 'description-a-b' (made from grid values, which keep ",
    ),
    "a grid key that does not exist": (
        '[grid]\n"brain.popsiz" = [2, 4]\n',
        "grid: 'brain.popsiz': no such key; keys under brain:",
    ),
    "the executor per condition": (
        '[[condition]]\nname = "x"\nset = { "executor.workers" = 2 }\n',
        "'executor.workers' cannot be set per condition",
    ),
    "an unknown seeding": (
        'seeding = "paired"\n',
        """seeding: must be "shared" or "independent" (got 'paired')""",
    ),
    "a condition name no folder may have": (  # was the pattern itself (probe G4)
        '[[condition]]\nname = "caf\u00e9"\n',
        "condition.0.name: a name is ASCII letters, digits and . _ - (it names a folder) "
        "(got 'caf\u00e9')",
    ),
    "unknown plugin in a condition": (
        '[[condition]]\nname = "x"\nset = { "world.name" = "nope" }\n',
        "world.name: unknown world 'nope'",
    ),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_campaign_files_are_one_line_exit_2_and_write_nothing(
    case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rest, expected = CASES[case]
    file = tmp_path / "campaign.toml"
    file.write_text(_GOOD.format(rest=rest))
    out = tmp_path / "out"
    assert exit_code(["campaign", "run", str(file), "--out", str(out), "--quiet"]) == 2
    line = one_error_line(capsys, quiet=True)
    assert expected in line, line
    assert not out.exists()


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ('base = { name = "t" }\nseeds = []\n', "seeds: the list is empty"),
        ('base = { name = "t" }\n', "give either seeds = [..] or seed_count = N"),
        ('base = { name = "t" }\nseeds = [1, 1]\n', "seeds: duplicate seeds"),
        ('base = "missing.toml"\nseeds = [1]\n', "base: experiment file"),
        ('base = { name = "t", brain = { popsize = 1 } }\nseeds = [1]\n', "brain.popsize"),
    ],
)
def test_bad_seeds_and_bases_are_config_errors(text: str, expected: str, tmp_path: Path) -> None:
    file = tmp_path / "c.toml"
    file.write_text(text)
    with pytest.raises(ConfigError, match=expected.replace("[", r"\[").replace(".", r"\.")):
        load_campaign_file(file)


def test_an_existing_campaign_folder_is_refused_and_left_as_it_was(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    file = tmp_path / "campaign.toml"
    file.write_text(_GOOD.format(rest=""))
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert exit_code(["campaign", "run", str(file), "--out", str(out)]) == 2
    assert one_error_line(capsys).endswith(
        "already exists; choose another --out, or empty it (it is not a campaign folder: there "
        "is nothing to continue)"
    )
    assert [p.name for p in out.iterdir()] == ["notes.txt"]
    assert exit_code(["campaign", "status", str(tmp_path)]) == 2
    assert "not an ariel campaign folder" in one_error_line(capsys)
    assert exit_code(["campaign", "resume", str(tmp_path)]) == 2
    assert "not an ariel campaign folder" in one_error_line(capsys)


def _two_conditions(**top: object) -> dict:
    return {
        "base": BASE,
        **top,
        "condition": [{"name": "a"}, {"name": "b", "set": {"brain.inherit": True}}],
    }


def test_conditions_share_their_seeds_by_default() -> None:
    spec = campaign_spec(_two_conditions(seed_count=3))
    assert spec.seeding == "shared"
    assert spec.seeds_of("a") == spec.seeds_of("b") == [1, 2, 3]
    assert sorted(spec.configs) == [(c, s) for c in ("a", "b") for s in (1, 2, 3)]


@pytest.mark.parametrize(
    ("seeds", "second"), [([1, 2, 3], [4, 5, 6]), ([1, 100], [101, 200]), ([5, 3], [8, 6])]
)
def test_independent_seeding_gives_every_condition_its_own_seeds(
    seeds: list[int], second: list[int]
) -> None:
    """Condition i runs each seed + i x (max - min + 1): deterministic, and no two conditions
    share a seed."""
    spec = campaign_spec(_two_conditions(seeds=seeds, seeding="independent"))
    assert spec.seeding == "independent" and spec.seeds == seeds
    assert spec.seeds_of("a") == seeds and spec.seeds_of("b") == second
    assert not set(spec.seeds_of("a")) & set(spec.seeds_of("b"))
    for condition, seed in spec.configs:
        assert spec.configs[(condition, seed)].seed == seed
    assert campaign_spec(_two_conditions(seeds=seeds, seeding="independent")).configs.keys() == (
        spec.configs.keys()
    )


def test_campaign_json_records_the_seeding_and_old_ones_read_as_shared(tmp_path: Path) -> None:
    from types import SimpleNamespace

    from ariel.recording.store._campaign import Campaign
    from ariel.runs._campaign_info import campaign_info

    spec = campaign_spec(_two_conditions(seed_count=2, seeding="independent"))
    settings = SimpleNamespace(kind="serial", workers=1, address=None)
    info = campaign_info(spec, [], settings, "c-1", "c.toml")
    assert info["seeding"] == "independent" and info["seeds"] == [1, 2]
    assert info["base"] == "inline"
    assert [c["seeds"] for c in info["conditions"]] == [[1, 2], [3, 4]]
    assert Campaign(tmp_path, info).seeding == "independent"
    del info["seeding"]  # a campaign.json from before the key: its conditions shared seeds
    assert Campaign(tmp_path, info).seeding == "shared"


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda out: out.symlink_to(out.parent / "nowhere"), "is a symbolic link (to "),
        (lambda out: out.write_text("mine"), "is a file; choose another --out"),
    ],
    ids=["dangling-link", "file"],
)
def test_an_out_that_is_a_link_or_a_file_is_refused_in_so_many_words(
    make, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    file = tmp_path / "campaign.toml"
    file.write_text(_GOOD.format(rest=""))
    out = tmp_path / "out"
    make(out)
    listing = sorted(p.name for p in tmp_path.iterdir())
    assert exit_code(["campaign", "run", str(file), "--out", str(out)]) == 2
    assert message in one_error_line(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == listing  # nothing made, not followed
