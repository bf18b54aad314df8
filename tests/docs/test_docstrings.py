"""Every public name's docstring is complete: the API reference is built from them.

The docstrings are Google style (``Args:``, ``Returns:``, ``Raises:``, ``Example:``), parsed by
griffe exactly as the docs site's mkdocstrings does; a docstring griffe warns about (a
parameter that is not in the signature, say) fails here, as it fails the site's strict build.
"""

from __future__ import annotations

import dataclasses
import enum
import inspect
import logging
from collections.abc import Iterator

import griffe
import pytest

from tests.docs._api import public_modules

_SKIPPED_PARAMETERS = {"self", "cls"}


def _documented(obj: griffe.Object, kind: griffe.DocstringSectionKind) -> set[str]:
    names: set[str] = set()
    if obj.docstring is None:
        return names
    for section in obj.docstring.parsed:
        if section.kind is kind:
            for item in section.value:
                names.add(item.name.lstrip("*"))
    return names


def _has_section(obj: griffe.Object, kind: griffe.DocstringSectionKind) -> bool:
    return obj.docstring is not None and any(s.kind is kind for s in obj.docstring.parsed)


@pytest.fixture(scope="module")
def package() -> Iterator[tuple[griffe.Module, list[str]]]:
    warnings: list[str] = []

    class Collect(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            warnings.append(record.getMessage())

    handler = Collect(level=logging.WARNING)
    logger = logging.getLogger("griffe")
    logger.addHandler(handler)
    try:
        loaded = griffe.load("ariel", docstring_parser="google", resolve_aliases=True)
        for obj in _walk(loaded):
            if obj.docstring is not None:
                obj.docstring.parsed  # noqa: B018 (parsing is what logs the warnings)
        yield loaded, warnings
    finally:
        logger.removeHandler(handler)


def _walk(obj: griffe.Object) -> Iterator[griffe.Object]:
    yield obj
    for member in obj.members.values():
        if member.is_alias:
            continue
        if member.is_module or member.is_class or member.is_function or member.is_attribute:
            yield from _walk(member)  # type: ignore[arg-type]


def test_docstrings_parse_without_warnings(package) -> None:
    _, warnings = package
    assert not warnings, "griffe warns about docstrings:\n" + "\n".join(warnings)


def _public_objects() -> list[tuple[str, object]]:
    """(dotted path where defined, object) of every public function and class, once each."""
    seen: dict[int, tuple[str, object]] = {}
    for module in public_modules():
        for name in module.__all__:
            obj = getattr(module, name)
            if not (inspect.isfunction(obj) or inspect.isclass(obj)):
                continue
            home = getattr(obj, "__module__", "") or ""
            if not home.startswith("ariel"):
                continue  # a re-exported third-party name (documented upstream)
            seen.setdefault(id(obj), (f"{home}.{obj.__qualname__}", obj))
    return sorted(seen.values(), key=lambda item: item[0])


def _missing(path: str, obj: object, package: griffe.Module) -> list[str]:
    if "<locals>" in path:  # made by a factory function: only its runtime docstring exists
        return [] if inspect.getdoc(obj) else [f"{path}: no docstring"]
    try:
        target = package[path.removeprefix("ariel.")]
    except (KeyError, ValueError):
        return [f"{path}: griffe cannot find it"]
    if target.is_alias:
        target = target.final_target
    if not target.docstring:
        return [f"{path}: no docstring"]
    params = griffe.DocstringSectionKind.parameters
    problems: list[str] = []
    if inspect.isclass(obj):
        if issubclass(obj, enum.Enum | BaseException):
            return problems  # their constructors are the base class's
        init = target.members.get("__init__")
        own_init = "__init__" in vars(obj) and not dataclasses.is_dataclass(obj)
        signature_of = init if own_init and init is not None else None
        if signature_of is None:
            fields = _fields(obj)
            documented = _documented(target, griffe.DocstringSectionKind.attributes) | (
                _documented(target, params)
            )
            lacking = [f for f in fields if f not in documented]
            return [f"{path}: fields not documented: {lacking}"] if lacking else problems
        documented = _documented(target, params) | _documented(signature_of, params)
        names = [p.name for p in signature_of.parameters if p.name not in _SKIPPED_PARAMETERS]
    else:
        documented = _documented(target, params)
        names = [p.name for p in target.parameters if p.name not in _SKIPPED_PARAMETERS]
        returns = target.returns
        if returns is not None and str(returns) not in ("None", "NoReturn", "Never"):
            kinds = (griffe.DocstringSectionKind.returns, griffe.DocstringSectionKind.yields)
            if not any(_has_section(target, kind) for kind in kinds):
                problems.append(f"{path}: no Returns section")
    lacking = [name for name in names if name not in documented]
    if lacking:
        problems.append(f"{path}: parameters not documented: {lacking}")
    return problems


def _fields(cls: type) -> list[str]:
    if dataclasses.is_dataclass(cls):
        return [f.name for f in dataclasses.fields(cls) if not f.name.startswith("_")]
    model_fields = getattr(cls, "model_fields", None)
    if isinstance(model_fields, dict):
        return [name for name in model_fields if not name.startswith("_")]
    annotations = getattr(cls, "__annotations__", {})
    if hasattr(cls, "_fields"):  # NamedTuple
        return [name for name in annotations if not name.startswith("_")]
    return []


def test_every_public_function_and_class_documents_its_parameters(package) -> None:
    loaded, _ = package
    problems = [p for path, obj in _public_objects() for p in _missing(path, obj, loaded)]
    assert not problems, f"{len(problems)} incomplete docstrings:\n" + "\n".join(problems)


def test_no_sphinx_roles_reach_the_api_reference() -> None:
    """The reference reads Google-style docstrings: ``:func:`x``` was shown as literal text
    (Markdown backticks, `x`, are what it renders)."""
    import re
    from pathlib import Path

    role = re.compile(r":(?:func|meth|class|mod|attr|obj|data|exc):`")
    ariel = Path(__file__).resolve().parents[2] / "ariel"
    found = [
        f"{path.relative_to(ariel.parent)}:{number}"
        for path in sorted(ariel.rglob("*.py"))
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if role.search(line)
    ]
    assert not found, found
