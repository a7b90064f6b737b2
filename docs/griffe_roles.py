"""Griffe extension of the API reference: the package's reST-style roles become links.

The docstrings cross-reference with Sphinx roles (``:func:`fit_gait```, ``:class:`~a.b.C```,
``:mod:`.compile```). Markdown does not know them, so before mkdocstrings renders a docstring
every role is resolved in the scope of the object that holds it (relative module names
against its package) and replaced by a mkdocstrings cross-reference to the object's own
page. A role that names nothing in ``pdw_casadi`` is a warning, and ``mkdocs build
--strict`` fails on it: a docstring cannot name a function that does not exist. Targets
outside the package (``numpy.ndarray``) and private ones (not rendered) stay code spans.
A reST literal-block marker (``text::`` before an indented block) becomes ``text:``.
"""

from __future__ import annotations

import logging
import re

import griffe

LOG = logging.getLogger("mkdocs.plugins.pdw_docs.roles")
ROLE = re.compile(r":(?:py:)?(func|class|mod|meth|data|attr|obj|exc|const):`(~?)([^`]+)`")
PACKAGE = "pdw_casadi"


def _private(path: str) -> bool:
    return any(p.startswith("_") and not p.startswith("__") for p in path.split("."))


def _lookup(obj: griffe.Object, path: str) -> str | None:
    """The canonical path of ``path`` (a dotted path in the loaded package), or None."""
    try:
        found = obj.modules_collection[path]
    except (KeyError, ValueError, griffe.AliasResolutionError, griffe.CyclicAliasError):
        return None
    try:
        return found.final_target.path if found.is_alias else found.path
    except (griffe.AliasResolutionError, griffe.CyclicAliasError):
        return None


def _module_of(obj: griffe.Object) -> griffe.Module:
    return obj if obj.is_module else obj.module


def resolve(obj: griffe.Object, target: str, package: str = PACKAGE) -> str | None:
    """The canonical dotted path that ``target`` names in the scope of ``obj``, or None."""
    target = target.strip().rstrip("()")
    if target.startswith("."):
        module = _module_of(obj)
        base = module.path.split(".")
        if not module.is_init_module:
            base.pop()
        dots = len(target) - len(target.lstrip("."))
        base = base[: len(base) - (dots - 1)] if dots > 1 else base
        return _lookup(obj, ".".join([*base, target.lstrip(".")]))
    if target.split(".")[0] == package:
        return _lookup(obj, target)
    head, _, rest = target.partition(".")
    scope: griffe.Object | None = obj
    while scope is not None:  # the object, its class, its module, its package...
        if head in scope.members:
            full = scope.members[head].path + (f".{rest}" if rest else "")
            return _lookup(obj, full)
        if head in getattr(scope, "imports", {}):
            full = scope.imports[head] + (f".{rest}" if rest else "")
            return _lookup(obj, full) if full.split(".")[0] == package else None
        scope = scope.parent
    return None


def _external(obj: griffe.Object, target: str, package: str = PACKAGE) -> bool:
    """A role that names something outside the package (numpy, argparse, ...)."""
    target = target.strip()
    if target.startswith("."):
        return False
    head = target.split(".")[0]
    if head == package:
        return False
    module = _module_of(obj)
    imported = getattr(module, "imports", {}).get(head)
    if imported is not None:
        return imported.split(".")[0] != package
    return "." in target and head not in module.members


def convert(obj: griffe.Object, text: str, package: str = PACKAGE) -> str:
    """``text`` (a docstring of ``obj``) with its roles as cross-references."""

    def link(m: re.Match) -> str:
        short, target = m.group(2), m.group(3)
        shown = target.strip().split(".")[-1] if short else target.strip().lstrip(".")
        if _private(target.lstrip(".")) or _external(obj, target, package):
            return f"`{shown}`"
        path = resolve(obj, target, package)
        if path is None:
            LOG.warning("%s: docstring names %r, which is not in %s", obj.path, target,
                        package)
            return f"`{shown}`"
        if _private(path):
            return f"`{shown}`"
        return f"[`{shown}`][{path}]"

    text = ROLE.sub(link, text)
    return re.sub(r"(\S)::\n", r"\1:\n", text)


class RolesToLinks(griffe.Extension):
    """Rewrite every docstring of the package once it is loaded (``package``: whose names
    the roles may use; other packages are left alone)."""

    def __init__(self, package: str = PACKAGE) -> None:
        super().__init__()
        self.package = package

    def on_package(self, *, pkg: griffe.Module, **kwargs) -> None:
        if pkg.name == self.package:
            self._walk(pkg, set())

    def _walk(self, obj: griffe.Object, seen: set[str]) -> None:
        if obj.path in seen:
            return
        seen.add(obj.path)
        if obj.docstring is not None:
            obj.docstring.value = convert(obj, obj.docstring.value, self.package)
        for member in obj.members.values():
            if not member.is_alias:
                self._walk(member, seen)
