"""Helpers for controllers (upstream's ``controllers.utils``)."""
