"""Robogen-lite modular bodies: core, brick and hinge modules, decoders and prebuilt robots."""
