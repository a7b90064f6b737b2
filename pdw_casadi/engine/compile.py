"""Compile CasADi functions to C once and cache the shared libraries on disk.

The simulator's hot functions (a chunk of RK4 steps, event location, the exact step
sensitivities) are evaluated thousands of times per step; compiled they run about ten times
faster than in CasADi's virtual machine. Libraries are cached by a hash of the serialized
function in ``$PDW_CACHE`` (default ``~/.cache/pdw_casadi``), so a walker is compiled once
per machine. ``PDW_NO_COMPILE=1`` (or a missing C compiler) falls back to the interpreter.

Calling a CasADi function from Python costs about 80 us (numpy -> DM conversions of every
argument), more than a whole chunk of RK4 steps computes. Hot loops therefore call the
compiled library directly through ctypes (:class:`Native`, about 3 us per call) with numpy
arrays in and out: ``Lazy.np`` / ``LazyGroup.np``. Without a compiler, ``np`` calls the
CasADi function and converts its outputs, with identical results.
"""

from __future__ import annotations

import atexit
import ctypes
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import zlib
from collections import OrderedDict
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path

import casadi as ca
import numpy as np

from pdw_casadi.engine import interrupt

_LOCK = threading.Lock()
#: compilers running for build_libraries, stopped when it is interrupted
_RUNNING: set = set()
_CANCEL = threading.Event()

#: gcc flags by what the generated code does (the one home of the optimisation levels).
#: ``HOT``: code that a hot loop calls many times and that loops itself (a chunk of RK4
#: steps, sensitivities through steps, shooting intervals); -Og keeps values in registers
#: like -O1 but skips its costliest passes. ``PLAIN``: straight-line code called a few times
#: per step (events, event location, outputs, margins, the section maps); gcc's optimiser
#: would cost several times the compile time for no measurable gain.
#: docs/results/performance.md has the figures.
HOT: tuple[str, ...] = ("-Og",)
PLAIN: tuple[str, ...] = ("-O0",)
#: never compiled: large expressions evaluated once per step or phase (an impact with its
#: impulse solve expanded, its Jacobians), where CasADi's virtual machine costs well under
#: a millisecond per call and gcc seconds per function on every walker's first run
INTERPRETED = None


def cache_dir() -> Path:
    return Path(os.environ.get("PDW_CACHE", Path.home() / ".cache" / "pdw_casadi"))


def compiler() -> str | None:
    """The C compiler to use, or None when compilation is disabled or unavailable."""
    if os.environ.get("PDW_NO_COMPILE", "") not in ("", "0"):
        return None
    return shutil.which(os.environ.get("CC", "gcc")) or shutil.which("cc")


_WARNED: set[str] = set()
_FALLBACK: list[Path] = []  # the temporary cache used when the configured one is unusable


def _warn(key: str, message: str) -> None:
    """One warning line per ``key`` and process."""
    if key not in _WARNED:
        _WARNED.add(key)
        print(f"warning: {message}", file=sys.stderr, flush=True)


def _usable_cache() -> Path | None:
    """The cache directory, or a temporary one (one warning) when it cannot be written;
    None when neither can (then the interpreter runs the functions)."""
    base = cache_dir()
    try:
        base.mkdir(parents=True, exist_ok=True)
        if not os.access(base, os.W_OK | os.X_OK):
            raise PermissionError(13, "not writable")
        return base
    except OSError as exc:
        reason = exc.strerror or str(exc)
    if not _FALLBACK:
        try:
            _FALLBACK.append(Path(tempfile.mkdtemp(prefix="pdw_casadi-cache-")))
            atexit.register(shutil.rmtree, _FALLBACK[0], True)  # this run's only
        except OSError:
            _warn("cache", f"compile cache {base} unusable ({reason}) and no temporary "
                           f"directory: running the functions uncompiled (slower)")
            return None
    _warn("cache", f"compile cache {base} unusable ({reason}); compiling into the temporary "
                   f"{_FALLBACK[0]} for this run")
    return _FALLBACK[0]


def _digest(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _record(so: Path) -> str:
    """The check recorded beside a library when it is built: its size and SHA-256."""
    return f"{so.stat().st_size} {_digest(so)}\n"


_PROBE = """
import ctypes, sys
lib = ctypes.CDLL(sys.argv[1])
for name in sys.argv[2:]:
    getattr(lib, name)
    n = getattr(lib, name + "_n_in"); n.restype = ctypes.c_longlong
    m = getattr(lib, name + "_n_out"); m.restype = ctypes.c_longlong
    print(n(), m())
"""


def _probe(so: Path, funs: list) -> bool:
    """Whether ``so`` loads and holds ``funs`` with their signatures, tried in a child
    process (a damaged library can crash the process that loads it)."""
    try:
        res = subprocess.run([sys.executable, "-c", _PROBE, str(so), *(f.name() for f in funs)],
                             capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return False
    want = "".join(f"{f.n_in()} {f.n_out()}\n" for f in funs)
    return res.returncode == 0 and res.stdout == want


#: libraries this process found intact, with the file's identity then (size, change time,
#: inode): a library whose file has not changed since is not read and summed again
_INTACT: dict[Path, tuple[int, int, int]] = {}


def _verified(so: Path, funs: list) -> str | None:
    """None when the cached ``so`` is intact, else why not. A library built by this
    module has its size and checksum beside it (``.sum``); an older one without it is
    probed in a child process once and then recorded."""
    record = so.with_suffix(".sum")
    try:
        st = so.stat()
        stamp = (st.st_size, st.st_mtime_ns, st.st_ino)
        if _INTACT.get(so) == stamp:
            return None
        size = st.st_size
        if size == 0:
            return "empty file"
        if record.exists():
            want = record.read_text()
            if want.split()[:1] != [str(size)]:
                return f"size {size} bytes, built as {want.split()[0] if want else '?'}"
            if want != _record(so):
                return "checksum differs from the build's"
        elif _probe(so, funs):
            _write_record(so)
        else:
            return "does not load or holds other functions"
        _INTACT[so] = stamp
        return None
    except OSError as exc:
        return exc.strerror or str(exc)


def _write_record(so: Path) -> None:
    tmp = so.with_suffix(f".sum.{os.getpid()}")
    try:
        tmp.write_text(_record(so))
        os.replace(tmp, so.with_suffix(".sum"))
    except OSError:
        tmp.unlink(missing_ok=True)  # unrecorded: probed again next time


def _build(funs: list, flags: tuple[str, ...], cc: str, so: Path) -> bool:
    """Compile ``funs`` into ``so`` (atomically, with its record); False when gcc fails."""
    name = funs[0].name()
    with tempfile.TemporaryDirectory(dir=so.parent) as tmp:
        src = f"{name}.c"
        cg = ca.CodeGenerator(src, {"with_header": False})
        for f in funs:
            cg.add(f)
        cg.generate(tmp + os.sep)
        out = Path(tmp) / f"{name}.so"
        if _CANCEL.is_set():
            return False
        proc = subprocess.Popen([cc, *flags, "-shared", "-fPIC", "-o", str(out),
                                 str(Path(tmp) / src)], stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        _RUNNING.add(proc)
        try:
            returncode = _wait(proc)
        except BaseException:
            proc.kill()
            proc.wait()
            raise
        finally:
            _RUNNING.discard(proc)
        if returncode != 0 or _CANCEL.is_set():
            return False
        record = Path(tmp) / "record"
        record.write_text(_record(out))
        # atomic: concurrent processes never see half a file; the record goes first so a
        # reader never takes a new library for a damaged one for long (at worst: rebuilt)
        os.replace(record, so.with_suffix(".sum"))
        os.replace(out, so)
    return True


def _wait(proc: subprocess.Popen) -> int:
    """The compiler's exit code; a signal that is pending (one a C++ call swallowed on the
    way) ends the wait and is raised, so a long compile never delays an interrupt."""
    while True:
        try:
            return proc.wait(timeout=0.2)
        except subprocess.TimeoutExpired:
            if interrupt.active():
                interrupt.check()


@contextmanager
def _machine_lock(so: Path):
    """Hold an exclusive lock on ``so``'s build across processes (parallel test workers,
    a cohort pool): the second process waits and then finds the library built instead of
    compiling it again. Without ``fcntl`` (not POSIX) or a lockable file: no lock (each
    process builds; the atomic replace keeps that safe, only slower)."""
    try:
        import fcntl  # deferred: POSIX only; without it the build runs unlocked
        f = open(so.with_suffix(".lock"), "a")
    except (ImportError, OSError):
        yield
        return
    with f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX)
        except OSError:
            pass
        yield


#: the cache key of recently hashed function lists, by identity: serialising a walker's
#: functions to hash them costs seconds, and a fit asks for each library several times (its
#: listing, then each first call). The entries hold the functions, so an identity is never
#: reused while it is recorded; bounded, so a long process does not keep every walker alive.
_KEYS: OrderedDict[tuple, tuple[list, str]] = OrderedDict()
_KEYS_MAX = 512


def _full_key(funs: list, flags: tuple[str, ...]) -> str:
    """The exact cache key of ``funs`` compiled with ``flags``: a hash of their
    serialization (about 0.4 s for a walker's fit functions)."""
    text = "".join(f.serialize() for f in funs) + " ".join(flags) + ca.__version__
    return hashlib.sha1(text.encode()).hexdigest()[:20]


def _signature(funs: list, flags: tuple[str, ...]) -> str:
    """A cheap fingerprint of ``funs`` (names, kinds, shapes, instruction and node counts):
    equal for the same functions, and also for functions of the same structure with other
    constants (another body's walker); :func:`_same_values` tells those apart."""
    parts = [ca.__version__, " ".join(flags)]
    for f in funs:
        shapes = [(f.size_in(i), f.nnz_in(i)) for i in range(f.n_in())] + \
            [(f.size_out(i), f.nnz_out(i)) for i in range(f.n_out())]
        parts.append(f"{f.name()}|{f.class_name()}|{f.n_instructions()}|{f.n_nodes()}|{shapes}")
    return hashlib.sha1("\n".join(parts).encode()).hexdigest()[:20]


#: relative difference up to which a compiled library and CasADi's virtual machine count
#: as the same function at the probe point (they run the same operations in the same
#: order; the slack covers the C compiler's and the machine's rounding)
SAME_VALUES_RTOL = 1e-9


def _same_values(funs: list, so: Path) -> bool:
    """Whether the library ``so`` computes ``funs`` at a fixed pseudo-random point: every
    output finite somewhere and equal to CasADi's own evaluation. Two functions of the
    same structure but other constants (the only ones :func:`_signature` confuses) differ
    there. NaN must sit at the same places; a function whose outputs are all NaN (or
    empty) at the point proves nothing and counts as different. One output all NaN beside
    finite ones is fine: an adjoint's seed of a guard that is undefined at a random point
    (the finite outputs carry the constants)."""
    rng = np.random.default_rng(20261207)
    for f in funs:
        args = [ca.DM(f.sparsity_in(i), rng.uniform(0.2, 0.8, f.nnz_in(i)))
                for i in range(f.n_in())]
        try:
            mine = f.call(args)
            theirs = ca.external(f.name(), str(so)).call(args)
        except RuntimeError:
            return False
        finite = False
        for a, b in zip(mine, theirs, strict=True):
            a, b = np.asarray(a.nonzeros(), float), np.asarray(b.nonzeros(), float)
            if a.shape != b.shape:
                return False
            if not np.allclose(a, b, rtol=SAME_VALUES_RTOL, atol=1e-12, equal_nan=True):
                return False
            finite = finite or bool(np.isfinite(a).any())
        if not finite:
            return False
    return True


#: keys remembered per signature (:func:`_cache_path`): walkers of the same structure
#: (bodies of a cohort) share a signature
_SIGNATURE_KEYS = 8


def _cache_path(funs: list, flags: tuple[str, ...]) -> Path | None:
    """Where the library of ``funs`` compiled with ``flags`` lives in the cache (None: no
    usable cache). The exact key hashes the functions' serialization; a process that finds
    a library under the functions' cheap :func:`_signature` (``keys/`` in the cache)
    checks that it is intact and computes the same values (:func:`_same_values`) instead
    of serializing them again."""
    ident = (tuple(id(f) for f in funs), flags)
    with _LOCK:
        hit = _KEYS.get(ident)
        if hit is not None:
            _KEYS.move_to_end(ident)
        base = _usable_cache()
    if base is None:
        return None
    if hit is not None:
        return base / f"{funs[0].name()}_{hit[1]}.so"
    index = base / "keys" / _signature(funs, flags)
    try:
        known = index.read_text().split()
    except OSError:
        known = []
    key = None
    for cand in known:
        so = base / f"{funs[0].name()}_{cand}.so"
        if so.is_file() and _verified(so, funs) is None and _same_values(funs, so):
            key = cand
            break
    if key is None:
        key = _full_key(funs, flags)
    if known[:1] != [key]:
        # the most recently used first: a process of one walker probes one library
        known = [key, *(k for k in known if k != key)][:_SIGNATURE_KEYS]
        try:
            index.parent.mkdir(exist_ok=True)
            tmp = index.with_suffix(f".{os.getpid()}.{threading.get_ident()}")
            tmp.write_text("\n".join(known) + "\n")
            os.replace(tmp, index)
        except OSError:
            pass  # not remembered: hashed again next time
    with _LOCK:
        _KEYS[ident] = (list(funs), key)
        while len(_KEYS) > _KEYS_MAX:
            _KEYS.popitem(last=False)
    return base / f"{funs[0].name()}_{key}.so"


def _library(funs: list, flags: tuple[str, ...], so: Path | None = None) -> Path | None:
    """Path of the cached shared library holding ``funs`` (built if missing or damaged),
    or None (no compiler, no usable cache, or a failed build: interpreted)."""
    cc = compiler()
    if cc is None:
        return None
    so = so or _cache_path(funs, flags)
    if so is None:
        return None
    base = so.parent
    # the per-library lock also serialises threads of this process (each opens the lock
    # file itself), so different libraries compile side by side (build_libraries)
    with _machine_lock(so):
        if so.exists():
            why = _verified(so, funs)
            if why is None:
                return so
            _warn(str(so), f"damaged compiled library {so} ({why}): rebuilt")
        try:
            if not _build(funs, flags, cc, so):
                return None
        except OSError as exc:  # e.g. the disk filled up: run uncompiled
            _warn("build", f"could not compile into {base} ({exc.strerror or exc}); "
                           f"running uncompiled")
            return None
    return so


def build_libraries(items, workers: int | None = None, log=None) -> int:
    """Compile the libraries of ``items`` (:class:`Lazy` and :class:`LazyGroup` objects)
    side by side, one compiler per core (``workers``, default all), into the cache that
    their first calls then load: a first run on a fresh machine waits for the longest
    library instead of for every library in turn. Libraries already cached are only
    verified. ``log``: called with one line when some are compiled. Returns the number of
    libraries compiled or verified (none without a compiler)."""
    if compiler() is None:
        return 0
    jobs, seen = [], set()
    # groups first (sensitivities through RK4 steps: the largest libraries), so that the
    # pool ends on small ones
    for item in sorted(items, key=lambda it: isinstance(it, Lazy)):
        if item.flags is None:
            continue
        funs = [item.fun] if isinstance(item, Lazy) else list(item.funs.values())
        key = (tuple(id(f) for f in funs), item.flags)
        if key not in seen:
            seen.add(key)
            jobs.append((funs, item.flags))
    n = max(1, min(workers or os.cpu_count() or 1, len(jobs)))
    paths = [_cache_path(funs, flags) for funs, flags in jobs]
    jobs = [(*job, so) for job, so in zip(jobs, paths, strict=True) if so is not None]
    missing = sum(1 for *_, so in jobs if not so.exists())
    if missing and log is not None:
        log(f"compiling {missing} functions of the walker on {n} cores (once per machine; "
            f"cached in {cache_dir()})")

    pool = ThreadPoolExecutor(n)
    try:
        for future in [pool.submit(_library, *job) for job in jobs]:
            future.result()
    except BaseException:
        # Ctrl-C or a signal: stop the compilers now (a library is only ever replaced
        # whole, so nothing half-built stays in the cache), then let the error through
        _CANCEL.set()
        for proc in list(_RUNNING):
            proc.kill()
        pool.shutdown(wait=True, cancel_futures=True)
        _CANCEL.clear()
        raise
    pool.shutdown(wait=True)
    return len(jobs)


def compiled(fun, flags: tuple[str, ...] = HOT):
    """``fun`` compiled to a cached shared library (or ``fun`` itself if no compiler).

    ``fun`` may be a list of functions: they go into one library, so that functions they
    share (a right-hand side and its Jacobian) are compiled once; a list is returned.
    ``flags``: :data:`HOT` for functions that loop internally (a chunk of steps),
    :data:`PLAIN` for straight-line expressions.
    """
    funs = list(fun) if isinstance(fun, list | tuple) else [fun]
    so = _library(funs, flags)
    if so is None:
        return fun
    ext = [ca.external(f.name(), str(so)) for f in funs]
    return ext if isinstance(fun, list | tuple) else ext[0]


#: stored functions kept per tag (:func:`stored`), the most recently used: one fit NLP's
#: row Jacobian is about 4 MB compressed, and each start gait's NLP has its own
STORED_KEEP = 16


def stored(source: ca.Function, build, tag: str, keep: int | None = None,
           as_loaded: bool = False) -> ca.Function:
    """The function ``build()`` derives from ``source`` (e.g. its Jacobian), built once per
    machine and kept serialized (zlib) in the cache (``tag_<key>.casadi.z``), keyed by
    ``source``'s serialization and CasADi's version: a new process loads it (about half the
    time of building an expanded Jacobian) instead of differentiating again. The ``keep``
    (default :data:`STORED_KEEP`) most recently used of a tag are kept. Without a usable
    cache, or when the stored file does not load, it is built (and stored again).
    ``as_loaded``: a function just built is returned as a later process loads it (read
    back from its serialization), so that what is derived from it and keyed by its own
    serialization (the rows' Jacobian of an NLP calling it) is the same in every process."""
    with _LOCK:
        base = _usable_cache()
    if base is None:
        return build()
    key = hashlib.sha1((source.serialize() + ca.__version__).encode()).hexdigest()[:20]
    path = base / f"{tag}_{key}.casadi.z"
    if path.is_file():
        try:
            fun = ca.Function.deserialize(zlib.decompress(path.read_bytes()).decode())
            os.utime(path)  # recently used: kept
            return fun
        except (OSError, RuntimeError, zlib.error, UnicodeDecodeError):
            _warn(str(path), f"damaged stored function {path}: rebuilt")
    fun = build()
    tmp = path.with_suffix(f".{os.getpid()}.tmp")
    text = fun.serialize()
    if as_loaded:
        fun = ca.Function.deserialize(text)
    try:
        # level 1: a ninth of the text's size, decompressed in a tenth of a second
        tmp.write_bytes(zlib.compress(text.encode(), 1))
        os.replace(tmp, path)  # atomic: a concurrent reader never sees half a file
        old = sorted(base.glob(f"{tag}_*.casadi.z"), key=lambda q: q.stat().st_mtime)
        for q in old[:-(STORED_KEEP if keep is None else keep)]:
            q.unlink(missing_ok=True)
    except (OSError, RuntimeError):
        tmp.unlink(missing_ok=True)  # not stored: built again next time
    return fun


#: functions with their common subexpressions merged kept (:func:`cse_function`): a few
#: dozen per walker, 10-120 kB each
CSE_KEEP = 512


def cse_function(name: str, ins: list, outs: list, names_in: list[str] | None = None,
                 names_out: list[str] | None = None) -> ca.Function:
    """``ca.Function(name, ins, outs[, names_in, names_out], {"cse": True})``: an SX
    function whose repeated subexpressions are merged (sin/cos of the same angles, the
    mass matrix's products: 10-50 % fewer operations, the same values). Merging costs
    20-70 ms per function of a 6-link walker, paid by every process that builds the walker;
    the merged function is therefore :func:`stored` in the cache, keyed by the function
    before merging (cheap to build), and loaded in a few milliseconds."""
    names = [] if names_in is None else [names_in, names_out]
    plain = ca.Function(name, ins, outs, *names)
    return stored(plain, lambda: ca.Function(name, ins, outs, *names, {"cse": True}), "cse",
                  keep=CSE_KEEP, as_loaded=True)


_INT = ctypes.c_longlong  # casadi_int of the generated code
_PTR = ctypes.POINTER(ctypes.c_double)


class Native:
    """A compiled CasADi function called directly through ctypes: numpy arrays in and out.

    Arguments are copied into preallocated buffers (any array-like of the input's size, or
    a float), outputs are returned as new 2-D arrays (rows x columns, like ``DM.full()``);
    a single output is returned bare, several as a tuple. A lock makes the shared work
    buffers safe across threads.
    """

    def __init__(self, fun: ca.Function, so: Path):
        self._fun, self._so = fun, so
        lib = ctypes.CDLL(str(so))
        name = fun.name()
        self._call = getattr(lib, name)
        self._call.restype = ctypes.c_int
        getattr(lib, name + "_incref")()
        mem = getattr(lib, name + "_checkout")()  # this object's memory slot, kept for life
        sz = [_INT() for _ in range(4)]
        getattr(lib, name + "_work")(*(ctypes.byref(v) for v in sz))
        n_arg, n_res, n_iw, n_w = (max(int(v.value), 1) for v in sz)
        self._in = [np.zeros(fun.nnz_in(i)) for i in range(fun.n_in())]
        self._out = [np.zeros(fun.nnz_out(i)) for i in range(fun.n_out())]
        for i in range(fun.n_in()):
            if not fun.sparsity_in(i).is_dense():
                raise ValueError(f"{name}: sparse input {i} is not supported")
        self._shape_out = []  # (rows, cols, None) dense, or (rows, cols, (r, c)) triplets
        for i in range(fun.n_out()):
            sp = fun.sparsity_out(i)
            tri = None if sp.is_dense() else tuple(np.array(v, dtype=np.intp)
                                                       for v in sp.get_triplet())
            self._shape_out.append((sp.size1(), sp.size2(), tri))
        self._iw = np.zeros(n_iw, dtype=np.int64)
        self._w = np.zeros(n_w)
        self._arg = (_PTR * n_arg)(*[b.ctypes.data_as(_PTR) for b in self._in])
        self._res = (_PTR * n_res)(*[b.ctypes.data_as(_PTR) for b in self._out])
        self._args = (self._arg, self._res, self._iw.ctypes.data_as(ctypes.POINTER(_INT)),
                      self._w.ctypes.data_as(_PTR), ctypes.c_int(mem))
        self._lock = threading.Lock()

    def __call__(self, *args):
        with self._lock:
            for buf, a in zip(self._in, args, strict=True):
                if type(a) is np.ndarray and a.ndim == 1:
                    buf[:] = a
                elif isinstance(a, _SCALAR):
                    buf[0] = a
                else:
                    buf[:] = np.ravel(a, order="F")
            if self._call(*self._args) != 0:
                raise RuntimeError("compiled CasADi function failed")
            outs = [self._dense(k) for k in range(len(self._out))]
        return outs[0] if len(outs) == 1 else tuple(outs)

    def clone(self) -> Native:
        """The same compiled function with buffers and a memory slot of its own: calls of
        the two run side by side in threads (ctypes releases the GIL during the call)."""
        return Native(self._fun, self._so)

    def _dense(self, k):
        rows, cols, tri = self._shape_out[k]
        if tri is None:
            return self._out[k].reshape((rows, cols), order="F").copy(order="F")
        full = np.zeros((rows, cols))
        full[tri[0], tri[1]] = self._out[k]
        return full


_SCALAR = (float, int)


def interpreted(fun: ca.Function):
    """Fallback for :class:`Native`: the CasADi function, outputs as numpy arrays."""

    def call(*args):
        outs = fun.call([np.asarray(a, float).reshape(-1, 1, order="F")
                         if not isinstance(a, float | int) else a for a in args])
        outs = [np.asarray(o, float) for o in outs]
        return outs[0] if len(outs) == 1 else tuple(outs)

    return call


def native(funs: list, flags: tuple[str, ...]) -> list:
    """Numpy-level callables of ``funs`` compiled together (interpreted without a compiler)."""
    so = _library(funs, flags)
    if so is None:
        return [interpreted(f) for f in funs]
    return [Native(f, so) for f in funs]


class LazyGroup:
    """Functions compiled together into one library on the first call of any of them."""

    def __init__(self, funs: dict, flags: tuple[str, ...] = PLAIN):
        self.funs = funs
        self.flags = flags
        self._fast: dict | None = None
        self._np: dict | None = None

    def _lazy(self, attr: str, build, key):
        """Callable of function ``key``; the whole group is built by ``build`` on first use."""
        group = self

        def call(*args):
            if getattr(group, attr) is None:
                keys = list(group.funs)
                setattr(group, attr, dict(zip(keys, build([group.funs[k] for k in keys],
                                                          group.flags), strict=True)))
            return getattr(group, attr)[key](*args)

        return call

    def np(self, key):
        """Numpy-level callable of function ``key`` (see :class:`Native`)."""
        return self._lazy("_np", native, key)


class Lazy:
    """A CasADi function compiled on first call (calls with the same signature as ``fun``).

    ``lazy(...)`` returns CasADi DMs like the function; ``lazy.np(...)`` takes and returns
    numpy arrays through :class:`Native` (for hot loops).
    """

    def __init__(self, fun: ca.Function, flags: tuple[str, ...] | None = PLAIN):
        self.fun = fun
        self.flags = flags  # INTERPRETED (None): never compiled
        self._fast: ca.Function | None = None
        self._np = None

    def __call__(self, *args):
        if any(isinstance(a, ca.SX | ca.MX) for a in args):
            return self.fun(*args)  # symbolic use (e.g. in an NLP): keep CasADi's derivatives
        if self._fast is None:
            self._fast = self.fun if self.flags is None else compiled(self.fun, self.flags)
        return self._fast(*args)

    def np(self, *args):
        if self._np is None:
            self._np = (interpreted(self.fun) if self.flags is None
                        else native([self.fun], self.flags)[0])
        return self._np(*args)

    def __getattr__(self, item):
        return getattr(self.fun, item)
