"""Compile CasADi functions to C once and cache the shared libraries on disk.

The simulator's hot functions (a chunk of RK4 steps, event location, the exact step
sensitivities) are evaluated thousands of times per step; compiled they run about ten times
faster than in CasADi's virtual machine. Libraries are cached by a hash of the serialized
function in ``$PDW_CACHE`` (default ``~/.cache/pdw_casadi``), so a walker is compiled once
per machine. ``PDW_NO_COMPILE=1`` (or a missing C compiler) falls back to the interpreter.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
import threading
from pathlib import Path

import casadi as ca

_LOCK = threading.Lock()


def cache_dir() -> Path:
    return Path(os.environ.get("PDW_CACHE", Path.home() / ".cache" / "pdw_casadi"))


def compiler() -> str | None:
    """The C compiler to use, or None when compilation is disabled or unavailable."""
    if os.environ.get("PDW_NO_COMPILE", "") not in ("", "0"):
        return None
    return shutil.which(os.environ.get("CC", "gcc")) or shutil.which("cc")


def compiled(fun, flags: tuple[str, ...] = ("-O1",)):
    """``fun`` compiled to a cached shared library (or ``fun`` itself if no compiler).

    ``fun`` may be a list of functions: they go into one library, so that functions they
    share (a right-hand side and its Jacobian) are compiled once; a list is returned.
    ``-O1`` pays off for functions that loop internally (a chunk of steps); for large
    straight-line expressions gcc's optimiser costs minutes for little gain, use ``-O0``.
    """
    funs = list(fun) if isinstance(fun, list | tuple) else [fun]
    cc = compiler()
    if cc is None:
        return funs if isinstance(fun, list | tuple) else fun
    text = "".join(f.serialize() for f in funs) + " ".join(flags) + ca.__version__
    key = hashlib.sha1(text.encode()).hexdigest()[:20]
    name = funs[0].name()
    so = cache_dir() / f"{name}_{key}.so"
    with _LOCK:
        if not so.exists():
            so.parent.mkdir(parents=True, exist_ok=True)
            with tempfile.TemporaryDirectory(dir=so.parent) as tmp:
                src = f"{name}.c"
                cg = ca.CodeGenerator(src, {"with_header": False})
                for f in funs:
                    cg.add(f)
                cg.generate(tmp + os.sep)
                out = Path(tmp) / f"{name}.so"
                res = subprocess.run([cc, *flags, "-shared", "-fPIC", "-o", str(out),
                                      str(Path(tmp) / src)], capture_output=True, text=True)
                if res.returncode != 0:
                    return fun
                os.replace(out, so)  # atomic: concurrent processes never see half a file
    ext = [ca.external(f.name(), str(so)) for f in funs]
    return ext if isinstance(fun, list | tuple) else ext[0]


class LazyGroup:
    """Functions compiled together into one library on the first call of any of them."""

    def __init__(self, funs: dict, flags: tuple[str, ...] = ("-O0",)):
        self.funs = funs
        self.flags = flags
        self._fast: dict | None = None

    def __getitem__(self, key):
        group = self

        def call(*args):
            if group._fast is None:
                keys = list(group.funs)
                group._fast = dict(zip(keys, compiled([group.funs[k] for k in keys],
                                                      group.flags), strict=True))
            return group._fast[key](*args)

        return call


class Lazy:
    """A CasADi function compiled on first call (calls with the same signature as ``fun``)."""

    def __init__(self, fun: ca.Function, flags: tuple[str, ...] = ("-O0",)):
        self.fun = fun
        self.flags = flags
        self._fast: ca.Function | None = None

    def __call__(self, *args):
        if self._fast is None:
            self._fast = compiled(self.fun, self.flags)
        return self._fast(*args)

    def __getattr__(self, item):
        return getattr(self.fun, item)
