"""ARIEL workbench: evolve modular robots (body and brain) in MuJoCo.

Importing this package does nothing else: no folders, no logging set-up, no RNG seeding, and no
heavy imports (torch, matplotlib and rerun load only where they are used).
"""

__version__ = "0.1.0"
__all__ = ["__version__"]
