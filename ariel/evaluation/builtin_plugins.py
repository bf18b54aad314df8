"""In-tree plugin registrations.

`ariel.plugins` imports this module on the first lookup in any registry (never on
``import ariel``), so it may import mujoco, numpy and the worlds. Register with the decorators,
e.g. ``@controllers.register("na_cpg")``.
"""

# Placeholder: the built-in body encoders, worlds, controllers and fitness functions are
# registered here by the evaluation engine's author.
