"""ARIEL subpackage."""
