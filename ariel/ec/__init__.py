"""Evolutionary computation: genotypes (``ariel.ec.genotypes``) and upstream's EA engine.

The engine's names (``EA``, ``EAOperation``, ``Individual``, ``Population``, ``Crossover``, ...)
load from their modules on first access, so ``import ariel.ec`` imports no database library.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ariel.utils.lazy import lazy_face

if TYPE_CHECKING:  # the names as type checkers and the API reference see them
    from ariel.ec._mutators import (
        FloatMutator as FloatMutator,
        IntegerMutator as IntegerMutator,
    )
    from ariel.ec._operation import (
        EAOperation as EAOperation,
        EAStep as EAStep,
    )
    from ariel.ec._rng import (
        SEED as SEED,
        set_seed as set_seed,
    )
    from ariel.ec._settings import (
        DBHandlingMode as DBHandlingMode,
        EASettings as EASettings,
        config as config,
    )
    from ariel.ec.archive import (
        Archive as Archive,
    )
    from ariel.ec.crossover import (
        Crossover as Crossover,
    )
    from ariel.ec.ea import (
        EA as EA,
    )
    from ariel.ec.generators import (
        Floats as Floats,
        FloatsGenerator as FloatsGenerator,
        Integers as Integers,
        IntegersGenerator as IntegersGenerator,
    )
    from ariel.ec.individual import (
        Individual as Individual,
        JSONIterable as JSONIterable,
        JSONPrimitive as JSONPrimitive,
        JSONType as JSONType,
    )
    from ariel.ec.population import (
        Population as Population,
    )

# public name -> module that defines it (upstream ARIEL's ariel.ec exports, plus its older ones)
_LAZY: dict[str, str] = {
    "Archive": "ariel.ec.archive",
    "Crossover": "ariel.ec.crossover",
    "EA": "ariel.ec.ea",
    "DBHandlingMode": "ariel.ec._settings",
    "EAOperation": "ariel.ec._operation",
    "EASettings": "ariel.ec._settings",
    "EAStep": "ariel.ec._operation",
    "config": "ariel.ec._settings",
    "SEED": "ariel.ec._rng",
    "set_seed": "ariel.ec._rng",
    "FloatMutator": "ariel.ec._mutators",
    "IntegerMutator": "ariel.ec._mutators",
    "Floats": "ariel.ec.generators",
    "FloatsGenerator": "ariel.ec.generators",
    "Integers": "ariel.ec.generators",
    "IntegersGenerator": "ariel.ec.generators",
    "Individual": "ariel.ec.individual",
    "JSONIterable": "ariel.ec.individual",
    "JSONPrimitive": "ariel.ec.individual",
    "JSONType": "ariel.ec.individual",
    "Population": "ariel.ec.population",
}

__all__ = sorted(_LAZY)


__getattr__, __dir__ = lazy_face(__name__, _LAZY)
