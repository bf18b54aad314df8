# MuJoCo's Python bindings are compiled (pybind11) and ship no type stubs, so a type checker
# knows none of their names; this stub makes each one `Any` (pyright reads ./typings).
from typing import Any

def __getattr__(name: str) -> Any: ...
