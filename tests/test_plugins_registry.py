"""Plugin registries: registration, lookup errors, entry points, provenance."""

from __future__ import annotations

import subprocess
import sys
from typing import Any

import pytest

import ariel
from ariel import plugins
from ariel.plugins import (
    ENTRY_POINT_GROUPS,
    REGISTRIES,
    DuplicatePluginError,
    PluginLoadError,
    Registry,
    UnknownPluginError,
    fitness_function,
    fitness_functions,
)

PKG = "ariel_test_plugin_pkg"

CONSTANT_ONE_SOURCE = """
    from ariel.plugins import fitness_function


    @fitness_function(maximise=True)
    def constant_one(trajectory):
        return 1.0
"""


def make_registry(**kwargs: Any) -> Registry[Any]:
    kwargs.setdefault("check", None)
    return Registry("controller", **kwargs)


class Alpha:
    def __init__(self, **options: Any) -> None:
        self.options = options


class Beta:
    pass


def fitness_without_direction(trajectory: Any) -> float:
    return 0.0


@fitness_function(maximise=True)
def marked_fitness(trajectory: Any) -> float:
    return 1.0


# --- registration ---------------------------------------------------------------------------


def test_register_as_decorator_and_as_call() -> None:
    registry = make_registry()

    @registry.register("alpha")
    class Decorated:
        pass

    returned = registry.register("beta", Beta)
    assert returned is Beta
    assert registry.get("alpha") is Decorated
    assert registry.get("beta") is Beta
    assert registry.names() == ["alpha", "beta"]
    assert "alpha" in registry and "gamma" not in registry
    assert len(registry) == 2 and list(registry) == ["alpha", "beta"]


def test_make_calls_the_factory_with_options() -> None:
    registry = make_registry()
    registry.register("alpha", Alpha)
    made = registry.make("alpha", gain=2.0)
    assert isinstance(made, Alpha) and made.options == {"gain": 2.0}


def test_duplicate_name_is_an_error_naming_the_first_provider() -> None:
    registry = make_registry()
    registry.register("na_cpg", Alpha)
    with pytest.raises(DuplicatePluginError) as info:
        registry.register("na_cpg", Beta)
    assert str(info.value) == (f"controller 'na_cpg' is already registered (by {__name__}:Alpha)")
    assert isinstance(info.value, ValueError)
    assert registry.get("na_cpg") is Alpha


def test_replace_overrides_and_same_definition_is_idempotent() -> None:
    registry = make_registry()
    registry.register("x", Alpha)
    registry.register("x", Alpha)  # a reloaded module registers the same definition again
    registry.register("x", Beta, replace=True)
    assert registry.get("x") is Beta
    # Instances have no definition of their own: two instances of a class do clash.
    registry.register("inst", Alpha())
    with pytest.raises(DuplicatePluginError):
        registry.register("inst", Alpha())


def test_unknown_name_lists_known_names() -> None:
    registry = make_registry()
    registry.register("na_cpg", Alpha)
    registry.register("mlp", Beta)
    with pytest.raises(UnknownPluginError) as info:
        registry.get("foo")
    assert str(info.value) == "unknown controller 'foo'; known: mlp, na_cpg"
    # Catchable both ways: a lookup (KeyError) of a bad config value (ValueError).
    assert isinstance(info.value, KeyError) and isinstance(info.value, ValueError)
    with pytest.raises(UnknownPluginError, match=r"did you mean 'na_cpg'\?"):
        registry.make("na_cgp")
    with pytest.raises(UnknownPluginError, match=r"known: \(none\)"):
        make_registry().get("anything")


@pytest.mark.parametrize("bad", ["", " x", "two words", 3, None])
def test_bad_names_are_rejected(bad: Any) -> None:
    with pytest.raises(ValueError, match="name must be a non-empty string"):
        make_registry().register(bad, Alpha)


def test_unregister_removes_a_name() -> None:
    registry = make_registry()
    registry.register("alpha", Alpha)
    assert registry.unregister("alpha") is Alpha
    assert "alpha" not in registry
    with pytest.raises(UnknownPluginError):
        registry.unregister("alpha")


def test_make_refuses_a_non_callable() -> None:
    registry = make_registry()
    registry.register("value", 42)
    with pytest.raises(TypeError, match="controller 'value' is not callable"):
        registry.make("value")


def test_fitness_registry_checks_direction() -> None:
    registry = Registry("fitness", label="fitness function", check=plugins._check_fitness)
    with pytest.raises(TypeError, match="needs a bool attribute 'maximise'"):
        registry.register("none", fitness_without_direction)
    marked = fitness_function(maximise=False)(lambda trajectory: 0.0)
    registry.register("marked", marked)
    assert registry.get("marked").maximise is False
    assert isinstance(marked, plugins.FitnessFunction)
    with pytest.raises(TypeError, match="maximise must be True or False"):
        fitness_function(maximise="yes")  # type: ignore[arg-type]


# --- built-ins declared as "module:attr" strings --------------------------------------------


def test_declared_strings_are_imported_on_first_get_only(
    tmp_path: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "ariel_test_builtins_mod.py").write_text("def builtin_one():\n    return 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "ariel_test_builtins_mod", raising=False)
    registry = make_registry(builtins={"builtin_one": "ariel_test_builtins_mod:builtin_one"})

    assert registry.names() == ["builtin_one"]
    assert registry.provenance("builtin_one")["object"] == "ariel_test_builtins_mod:builtin_one"
    assert "ariel_test_builtins_mod" not in sys.modules  # listing and provenance import nothing
    assert registry.make("builtin_one") == 1
    assert "ariel_test_builtins_mod" in sys.modules
    assert registry.get("builtin_one") is sys.modules["ariel_test_builtins_mod"].builtin_one


def test_a_declared_string_that_cannot_load_fails_on_use_only() -> None:
    registry = Registry(
        "fitness",
        label="fitness function",
        check=plugins._check_fitness,
        builtins={
            "missing_module": "ariel_test_nowhere_mod:thing",
            "missing_attr": f"{__name__}:does_not_exist",
            "no_direction": f"{__name__}:fitness_without_direction",
            "marked": f"{__name__}:marked_fitness",
        },
    )
    # no "(None)" after a module that no installed distribution provides
    with pytest.raises(
        PluginLoadError,
        match=r"^could not load fitness function 'missing_module' from "
        r"ariel_test_nowhere_mod:thing: ModuleNotFoundError",
    ):
        registry.get("missing_module")
    with pytest.raises(PluginLoadError, match=rf"'missing_attr' from {__name__}:does_not_exist"):
        registry.get("missing_attr")
    with pytest.raises(PluginLoadError, match="needs a bool attribute 'maximise'"):
        registry.get("no_direction")
    assert registry.get("marked") is marked_fitness  # unaffected


@pytest.mark.parametrize("bad", ["no_colon", "mod:", ":attr", "a b:c", "mod:attr:more"])
def test_register_refuses_a_malformed_declaration(bad: str) -> None:
    with pytest.raises(ValueError, match="is not a 'module:attribute' string"):
        make_registry().register("x", bad)


def test_a_declared_string_and_its_object_are_one_definition() -> None:
    registry = make_registry(builtins={"alpha": f"{__name__}:Alpha"})
    registry.register("alpha", Alpha)  # the object the string names: no clash
    registry.register("alpha", f"{__name__}:Alpha")  # and the string again: none either
    assert registry.get("alpha") is Alpha
    with pytest.raises(DuplicatePluginError, match=f"already registered \\(by {__name__}:Alpha"):
        registry.register("alpha", Beta)
    with pytest.raises(DuplicatePluginError):
        registry.register("alpha", f"{__name__}:Beta")
    declared = make_registry(builtins={"beta": f"{__name__}:Beta"})
    assert declared.unregister("beta") is Beta  # the object, imported to be returned
    assert "beta" not in declared


def test_every_builtin_string_names_where_its_object_is_defined() -> None:
    """So provenance is the same whether a built-in was registered by string or by object."""
    assert set(plugins.BUILTIN_PLUGINS) == set(REGISTRIES)
    for kind, table in plugins.BUILTIN_PLUGINS.items():
        for name, path in table.items():
            obj = plugins._resolve(path)
            assert f"{obj.__module__}:{obj.__qualname__}" == path
            assert REGISTRIES[kind].provenance(name) == {
                "kind": kind,
                "name": name,
                "source": "registered",
                "object": path,
                "distribution": f"ariel=={ariel.__version__}",
            }


def test_importing_plugins_imports_no_engine() -> None:
    """Listing every name and every built-in's provenance imports no plugin, engine or MuJoCo."""
    code = (
        "import sys\n"
        "from ariel.plugins import REGISTRIES\n"
        "for registry in REGISTRIES.values():\n"
        "    for name in registry.names():\n"
        "        registry.provenance(name)\n"
        "print(' '.join(sorted(m for m in sys.modules if m.startswith('ariel'))))\n"
        "heavy = ['numpy', 'mujoco', 'torch', 'networkx', 'matplotlib', 'rerun', 'dask']\n"
        "print(' '.join(m for m in heavy if m in sys.modules))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    ariel_modules, heavy = out.split("\n")[:2]
    assert ariel_modules.split() == [
        "ariel",
        "ariel._builtin_names",
        "ariel._plugin_kinds",
        "ariel._plugin_registry",
        "ariel._version",
        "ariel.errors",
        "ariel.plugins",
        "ariel.utils",  # the face alone, for the GL check of a plugin that fails to import
        "ariel.utils.lazy",
    ]
    assert heavy == ""


# --- entry points ---------------------------------------------------------------------------


def test_entry_point_listed_without_import_and_loaded_on_first_use(fake_distribution) -> None:
    fake_distribution(
        PKG,
        "0.1",
        source=CONSTANT_ONE_SOURCE,
        entry_points={"ariel.fitness": {"constant_one": f"{PKG}:constant_one"}},
    )
    assert "constant_one" in fitness_functions.names()
    assert "constant_one" in fitness_functions
    provenance = fitness_functions.provenance("constant_one")
    assert provenance == {
        "kind": "fitness",
        "name": "constant_one",
        "source": "entry point",
        "object": f"{PKG}:constant_one",
        "distribution": f"{PKG}==0.1",
    }
    assert PKG not in sys.modules  # listing and provenance imported nothing

    fn = fitness_functions.get("constant_one")
    assert PKG in sys.modules
    assert fn.maximise is True and fn(None) == 1.0
    assert fitness_functions.get("constant_one") is fn  # loaded once
    assert plugins.plugin_provenance({"fitness": "constant_one"}) == {"fitness": provenance}


def test_entry_point_is_only_in_its_own_group(fake_distribution) -> None:
    fake_distribution(
        PKG,
        source=CONSTANT_ONE_SOURCE,
        entry_points={"ariel.fitness": {"constant_one": f"{PKG}:constant_one"}},
    )
    assert "constant_one" not in plugins.controllers.names()


def test_refresh_discovers_a_distribution_added_later(fake_distribution) -> None:
    registry = Registry("fitness", group="ariel.fitness")
    assert "constant_one" not in registry.names()
    fake_distribution(
        PKG,
        source=CONSTANT_ONE_SOURCE,
        entry_points={"ariel.fitness": {"constant_one": f"{PKG}:constant_one"}},
    )
    assert "constant_one" not in registry.names()  # discovery is cached ...
    registry.refresh()
    assert "constant_one" in registry.names()  # ... until refresh()


def test_entry_point_clashing_with_a_registered_name(fake_distribution) -> None:
    registry = Registry("fitness", group="ariel.fitness", label="fitness function")
    registry.register("constant_one", fitness_without_direction)
    fake_distribution(
        PKG,
        source=CONSTANT_ONE_SOURCE,
        entry_points={"ariel.fitness": {"constant_one": f"{PKG}:constant_one"}},
    )
    registry.refresh()
    assert registry.names().count("constant_one") == 1  # listing still works
    for lookup in (registry.get, registry.provenance):
        with pytest.raises(DuplicatePluginError) as info:
            lookup("constant_one")
        message = str(info.value)
        assert f"{__name__}:fitness_without_direction" in message
        assert f"{PKG}:constant_one ({PKG}==0.1)" in message
    # An explicit override wins.
    registry.register("constant_one", Alpha, replace=True)
    assert registry.get("constant_one") is Alpha
    # Registering over a discovered entry point fails at once.
    fresh = Registry("fitness", group="ariel.fitness")
    assert "constant_one" in fresh.names()
    with pytest.raises(DuplicatePluginError, match="already provided by entry point"):
        fresh.register("constant_one", Beta)


def test_two_distributions_declaring_one_name(fake_distribution) -> None:
    fake_distribution(
        PKG,
        source=CONSTANT_ONE_SOURCE,
        entry_points={"ariel.fitness": {"constant_one": f"{PKG}:constant_one"}},
    )
    fake_distribution(
        "ariel_test_plugin_other",
        "2.0",
        source=CONSTANT_ONE_SOURCE,
        entry_points={"ariel.fitness": {"constant_one": "ariel_test_plugin_other:constant_one"}},
    )
    registry = Registry("fitness", group="ariel.fitness", label="fitness function")
    assert "constant_one" in registry.names()
    with pytest.raises(DuplicatePluginError, match="declared by two entry points") as info:
        registry.get("constant_one")
    assert "ariel_test_plugin_other==2.0" in str(info.value)
    assert f"{PKG}==0.1" in str(info.value)


def test_broken_entry_points_fail_on_use_only(fake_distribution) -> None:
    fake_distribution(
        PKG,
        source=CONSTANT_ONE_SOURCE + "\n    def no_direction(trajectory):\n        return 0.0\n",
        entry_points={
            "ariel.fitness": {
                "constant_one": f"{PKG}:constant_one",
                "missing_attr": f"{PKG}:does_not_exist",
                "missing_module": f"{PKG}.nowhere:thing",
                "no_direction": f"{PKG}:no_direction",
            }
        },
    )
    registry = Registry(
        "fitness", group="ariel.fitness", label="fitness function", check=plugins._check_fitness
    )
    assert {"missing_attr", "missing_module", "no_direction"} <= set(registry.names())
    for name in ("missing_attr", "missing_module"):
        with pytest.raises(PluginLoadError, match=rf"could not load fitness function '{name}'"):
            registry.get(name)
    with pytest.raises(PluginLoadError, match=f"{PKG}==0.1.*needs a bool attribute 'maximise'"):
        registry.get("no_direction")
    assert registry.get("constant_one")(None) == 1.0  # unaffected


# --- provenance and the module-level registries ---------------------------------------------


def test_provenance_of_registered_objects() -> None:
    from ariel.evaluation import _selftest

    registry = make_registry()
    registry.register("from_ariel", _selftest.seeded_sum)
    registry.register("from_test", Alpha)
    assert registry.provenance("from_ariel") == {
        "kind": "controller",
        "name": "from_ariel",
        "source": "registered",
        "object": "ariel.evaluation._selftest:seeded_sum",
        "distribution": f"ariel=={ariel.__version__}",
    }
    # A test module belongs to no installed distribution.
    assert registry.provenance("from_test")["distribution"] is None
    assert registry.provenance("from_test")["object"] == f"{__name__}:Alpha"
    with pytest.raises(UnknownPluginError):
        registry.provenance("nope")


def test_the_four_registries() -> None:
    assert set(REGISTRIES) == set(ENTRY_POINT_GROUPS)
    for kind, registry in REGISTRIES.items():
        assert registry.kind == kind
        assert registry.group == ENTRY_POINT_GROUPS[kind]
        assert registry.group.startswith("ariel.")
        assert registry.names() == sorted(registry.names())
    with pytest.raises(ValueError, match="unknown plugin kind 'brain'"):
        plugins.plugin_provenance({"brain": "x"})


def test_throwaway_registration_on_a_module_registry() -> None:
    @plugins.controllers.register("test_throwaway_ctrl")
    class Throwaway:
        open_loop = True

    try:
        assert "test_throwaway_ctrl" in plugins.controllers.names()
        assert isinstance(plugins.controllers.make("test_throwaway_ctrl"), Throwaway)
        with pytest.raises(UnknownPluginError, match="test_throwaway_ctrl"):
            plugins.controllers.get("test_throwaway_ctl")
    finally:
        plugins.controllers.unregister("test_throwaway_ctrl")
    assert "test_throwaway_ctrl" not in plugins.controllers


def test_protocols_accept_a_conforming_controller() -> None:
    class SineController:
        open_loop = True

        def num_parameters(self, model: Any) -> int:
            return 2

        def random_parameters(self, model: Any, rng: Any, n: int) -> Any:
            return [[0.0, 0.0]] * n

        def targets(self, params: Any, sample_times: Any, model: Any, *, seed: int) -> Any:
            return params

    controller = SineController()
    assert isinstance(controller, plugins.ControllerPlugin)
    assert isinstance(controller, plugins.OpenLoopController)
    assert not isinstance(controller, plugins.ClosedLoopController)
    assert not isinstance(Beta(), plugins.ControllerPlugin)


def test_a_fitness_function_may_say_its_unit() -> None:
    assert fitness_functions.get("xy_displacement").unit == "m"
    assert fitness_functions.get("x_speed").unit == "m/s"

    @fitness_function(maximise=False)
    def no_unit(record: Any) -> float:
        return 0.0

    assert no_unit.unit is None and no_unit.maximise is False
    with pytest.raises(TypeError, match="unit must be a string"):
        fitness_function(maximise=True, unit=1)  # type: ignore[arg-type]
