"""The package version, in a module of its own: a low layer (`ariel.plugins`) reads it without
importing the package's top level, whose lazy API reaches up to the evolution driver."""

__version__ = "0.1.0"
