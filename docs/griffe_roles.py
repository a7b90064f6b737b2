"""Griffe extensions of the API reference: what it renders, and the package's reST-style
roles as links.

The docstrings cross-reference with Sphinx roles (``:func:`fit_gait```, ``:class:`~a.b.C```,
``:mod:`.compile```). Markdown does not know them, so before mkdocstrings renders a docstring
every role is resolved in the scope of the object that holds it (relative module names
against its package) and replaced by a mkdocstrings cross-reference to the object's own
page. A role that names nothing in ``pdw_casadi`` is a warning, and ``mkdocs build
--strict`` fails on it: a docstring cannot name a function that does not exist. Targets
outside the package (``numpy.ndarray``) and ones the reference does not render (private or
undocumented: :func:`rendered`) stay code spans.
A reST literal-block marker (``text::`` before an indented block) becomes ``text:``.

The curated API (:class:`CuratedApi`, run first): the reference renders with mkdocstrings'
``filters: public``, and this extension decides what is public. The page ``api/index.md``
holds the public API a user calls, by job: each ``::: path`` on it is that object's one
entry, so its module page leaves it out. The package's lazily resolved names (``_LAZY`` of
``pdw_casadi/__init__.py``, ``from pdw_casadi import fit_gait``) become members of the
package, so that the index renders them under the name a user imports; their module pages
keep them at home too. A name imported into a module (a re-export, even one in ``__all__``)
is documented at its home only; a private name (``_x``, ``__x__``) nowhere; any other name
defined in the package is public (a module's ``__all__`` hides nothing), and is rendered when
it has a docstring (``show_if_no_docstring: false``).
"""

from __future__ import annotations

import ast
import logging
import re
from pathlib import Path

import griffe

LOG = logging.getLogger("mkdocs.plugins.pdw_docs.roles")
ROLE = re.compile(r":(?:py:)?(func|class|mod|meth|data|attr|obj|exc|const):`(~?)([^`]+)`")
PACKAGE = "pdw_casadi"
#: the API index page; its ``::: path`` lines are the entries of the public API
INDEX = Path(__file__).resolve().parent / "api" / "index.md"
DIRECTIVE = re.compile(r"^::: *([\w.]+) *$", re.M)
#: where :class:`CuratedApi` marks an object rendered on the API index (``Object.extra``)
KEY = "pdw_docs"


def index_entries(text: str) -> list[str]:
    """The dotted paths of the ``::: path`` entries of a page, in order."""
    return DIRECTIVE.findall(text)


def rendered(obj: griffe.Object) -> bool:
    """Whether the reference renders ``obj`` (a non-alias object), so a link to it resolves:
    it is an entry of the API index, or it and every parent below its page's root are public
    with docstrings (mkdocstrings' ``filters: public`` and ``show_if_no_docstring: false``)."""
    while obj.parent is not None:
        if obj.extra.get(KEY, {}).get("index"):
            return True
        if not (obj.is_public and obj.has_docstrings):
            return False
        obj = obj.parent
    return True


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
        if _private(path) or not rendered(obj.modules_collection[path]):
            return f"`{shown}`"
        return f"[`{shown}`][{path}]"

    text = ROLE.sub(link, text)
    return re.sub(r"(\S)::\n", r"\1:\n", text)


class CuratedApi(griffe.Extension):
    """Decide what the reference renders (module docstring): the package's lazy names become
    its members; an entry of the API index is rendered there only, not again on its module
    page; a re-export at its home only; a private name nowhere. ``index``: the API index
    page (default :data:`INDEX`).
    Defined before :class:`RolesToLinks`, so that the roles link only what is rendered."""

    def __init__(self, package: str = PACKAGE, index: str | None = None) -> None:
        super().__init__()
        self.package = package
        self.index = Path(index) if index else INDEX

    def on_package(self, *, pkg: griffe.Module, **kwargs) -> None:
        if pkg.name != self.package:
            return
        face = self._face(pkg)
        homed: set[str] = set()
        for path in index_entries(self.index.read_text(encoding="utf-8")):
            try:
                obj = pkg.modules_collection[path]
            except KeyError:
                continue  # mkdocstrings fails the build on it, naming the page
            if obj.is_alias or obj is pkg:
                continue  # the package and its face: documented at home as well
            obj.extra[KEY]["index"] = True
            homed.add(obj.path)
        self._walk(pkg, homed, face, set())

    @staticmethod
    def _face(pkg: griffe.Module) -> set[str]:
        """Add the package's lazily resolved names (``_LAZY``: name -> module) as aliases."""
        lazy = pkg.members.get("_LAZY")
        if lazy is None or lazy.is_alias or getattr(lazy, "value", None) is None:
            return set()
        try:
            table = ast.literal_eval(str(lazy.value))
        except (ValueError, SyntaxError):
            LOG.warning("%s._LAZY is not a literal table of names", pkg.path)
            return set()
        for name, module in table.items():
            if name not in pkg.members:
                pkg.set_member(name, griffe.Alias(name, f"{module}.{name}", parent=pkg))
            pkg.members[name].public = True
        return set(table)

    def _walk(self, obj: griffe.Object, homed: set[str], face: set[str],
              seen: set[str]) -> None:
        if obj.path in seen:
            return
        seen.add(obj.path)
        for name, member in obj.members.items():
            if member.is_alias:
                if not (obj.parent is None and name in face):
                    member.public = False  # an import or a re-export: at its home only
                continue
            # a module's __all__ hides nothing documented: some lag behind their module
            # (TimingError, raised to users, is not in engine.errors.__all__)
            member.public = not (name.startswith("_") or member.path in homed)
            self._walk(member, homed, face, seen)


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
