"""The contract every console script keeps with its user.

1. Parse and validate *everything* first: argument syntax, numbers (finite, in range),
   files (exist, are files, parse), bounds, output paths (creatable and writable) and a Dask
   scheduler address (well formed, and answering). Nothing is written before that.
2. Only then create the output directory and work.
3. Bad input: one line ``error: ...`` on stderr and exit code 2 (argparse errors too: see
   :class:`Parser`), nothing written and nothing deleted.
4. The command ran but found no gait (no fixed point, numerical divergence, no stable valid
   fit): exit code 1 with a line ``no gait: <reason>`` (:class:`NoGait`).
5. Never a traceback: an unexpected exception is one line ``error: internal error ...``
   (exit code 1; ``PDW_DEBUG=1`` re-raises it with its traceback).
6. Ctrl-C (SIGINT) or SIGTERM ends with one line ``interrupted: ...`` naming what is on disk
   (exit code 130, 143 for SIGTERM); no solver swallows it (:mod:`pdw_casadi.engine.interrupt`).
7. Outputs are staged and moved into place only when the run completes (:class:`Outputs`):
   a failed or interrupted run leaves an earlier run's files whole. A failed write is exit
   code 1 with ``error: could not write FILE: reason``. One run at a time per directory.

A command body is ``run(outputs, body)``: ``outputs`` (:class:`Outputs`) knows the output
directory and records every file written, so the interruption line can name them.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import math
import os
import shutil
import signal
import sys
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import NoReturn
from urllib.parse import urlsplit

from pdw_casadi._version import __version__
from pdw_casadi.engine import interrupt
from pdw_casadi.engine.errors import (
    CurveError,
    GaitDataError,
    NoGait,
    ProblemError,
    UsageError,
    one_line,
)

#: exit codes of the contract
EXIT_OK, EXIT_NO_GAIT, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


#: exceptions that are the user's input, reported as ``error: ...`` with exit code 2
USER_ERRORS = (ProblemError, GaitDataError, CurveError, OSError)


def fail(message: object, code: int = EXIT_USAGE) -> NoReturn:
    """Print ``error: <message>`` (one line) to stderr and exit with ``code``."""
    print(f"error: {one_line(message)}", file=sys.stderr, flush=True)
    raise SystemExit(code)


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one ``error:`` line and exit code 2 (argparse
    prints the usage and the message on several lines), with ``--version``."""

    def __init__(self, *args, **kw):
        super().__init__(*args, **kw)
        self.add_argument("--version", action="version", version=f"%(prog)s {__version__}",
                          help="print the toolkit's version and exit")

    def error(self, message: str) -> NoReturn:
        # "argument --num: --num must be >= 2, got 1" -> "--num must be >= 2, got 1"
        head, sep, rest = message.partition(": ")
        if sep and head.startswith("argument ") and head[len("argument "):].split("/")[0] \
                in rest:
            message = rest
        fail(f"{self.prog}: {message} (see {self.prog} --help)")

    def exit(self, status: int = 0, message: str | None = None) -> NoReturn:
        if message:
            print(one_line(message), file=sys.stderr if status else sys.stdout)
        raise SystemExit(status)


# -- argument types ------------------------------------------------------------------------
def _number(flag: str, text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{flag} must be a number, got {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"{flag} must be a finite number, got {text!r}")
    return v


def finite_float(flag: str) -> Callable[[str], float]:
    """Type: a finite float."""
    def parse(text: str) -> float:
        return _number(flag, text)
    parse.__name__ = "number"
    return parse


def positive_float(flag: str, maximum: float = math.inf) -> Callable[[str], float]:
    """Type: a finite float > 0 (and <= ``maximum``)."""
    def parse(text: str) -> float:
        v = _number(flag, text)
        if not v > 0:
            raise argparse.ArgumentTypeError(f"{flag} must be > 0, got {text!r}")
        if v > maximum:
            raise argparse.ArgumentTypeError(f"{flag} must be <= {maximum:g}, got {text!r}")
        return v
    parse.__name__ = "positive number"
    return parse


def open_interval(flag: str, lo: float, hi: float) -> Callable[[str], float]:
    """Type: a finite float in (lo, hi)."""
    def parse(text: str) -> float:
        v = _number(flag, text)
        if not lo < v < hi:
            raise argparse.ArgumentTypeError(f"{flag} must be in ({lo:g}, {hi:g}), "
                                             f"got {text!r}")
        return v
    parse.__name__ = "number"
    return parse


def int_range(flag: str, lo: int = 1, hi: int | None = None) -> Callable[[str], int]:
    """Type: an integer in [lo, hi]."""
    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{flag} must be an integer, got {text!r}") \
                from None
        if v < lo:
            raise argparse.ArgumentTypeError(f"{flag} must be >= {lo}, got {v}")
        if hi is not None and v > hi:
            raise argparse.ArgumentTypeError(f"{flag} must be <= {hi}, got {v}")
        return v
    parse.__name__ = "integer"
    return parse


# -- paths -----------------------------------------------------------------------------------
def _existing_ancestor(path: Path) -> Path:
    path = Path(os.path.abspath(path))
    while not path.exists():
        path = path.parent
    return path


def check_writable_dir(path: Path, flag: str, shown: Path | None = None) -> None:
    """Raise :class:`UsageError` unless directory ``path`` exists or can be created, and
    files can be written in it. Nothing is left behind. ``shown``: the path named in the
    message (default ``path``)."""
    path = Path(path)
    shown = path if shown is None else shown
    if path.exists() and not path.is_dir():
        raise UsageError(f"{flag} {shown}: {path} exists and is not a directory")
    base = _existing_ancestor(path)
    if not base.is_dir():
        raise UsageError(f"{flag} {shown}: {base} is not a directory")
    try:  # the only reliable test (permissions, read-only or virtual file systems, root)
        with tempfile.TemporaryDirectory(dir=base, prefix=".pdw-write-test-"):
            pass
    except OSError as exc:
        raise UsageError(f"{flag} {shown}: cannot write in {base}: "
                         f"{exc.strerror or exc}") from None


def check_output_file(path: Path, flag: str, suffixes: tuple[str, ...] = ()) -> None:
    """Raise :class:`UsageError` unless file ``path`` can be written (its directory
    creatable and writable, not an existing directory, the right suffix)."""
    path = Path(path)
    if suffixes and path.suffix.lower() not in suffixes:
        raise UsageError(f"{flag} {path}: must end in {' or '.join(suffixes)}")
    if path.is_dir():
        raise UsageError(f"{flag} {path}: is a directory")
    if path.exists() and not os.access(path, os.W_OK):
        raise UsageError(f"{flag} {path}: exists and is not writable")
    check_writable_dir(path.parent, flag, shown=path)


def check_input_file(path: Path, flag: str) -> Path:
    """Raise :class:`UsageError` unless ``path`` is an existing regular file."""
    path = Path(path)
    if path.is_dir():
        raise UsageError(f"{flag} {path}: is a directory, not a file")
    if not path.exists():
        raise UsageError(f"{flag} {path}: file not found")
    if not path.is_file():
        raise UsageError(f"{flag} {path}: not a regular file")
    if not os.access(path, os.R_OK):
        raise UsageError(f"{flag} {path}: not readable")
    return path


class Outputs:
    """The output directory of a command run and the files written into it so far.

    Nothing is written in place: :meth:`create` locks the directory (a second run into it
    is refused) and returns a private staging folder inside it; :meth:`staged` gives a
    temporary name beside an output file that lives elsewhere. :func:`run` moves the staged
    files into place when the run completes (:meth:`commit`) and removes them when it
    fails or is interrupted (:meth:`discard`): an earlier run's files stay whole, never
    mixed with this run's.
    """

    STAGE_PREFIX = ".pdw-partial-"

    def __init__(self, directory: Path, flag: str = "--out"):
        self.dir = Path(directory)
        self.flag = flag
        self.created = False
        self.written: list[Path] = []
        self.notes: list[str] = []
        self.stage: Path | None = None
        self._outside: dict[Path, Path] = {}  # temporary file -> its final path
        self._keep: list[str] = []  # staged names kept when the run is interrupted
        #: names in the directory that a completed run removes (an earlier run's partials)
        self.obsolete: list[str] = []
        self._lock: int | None = None
        self.committed: list[Path] = []

    def check(self) -> None:
        check_writable_dir(self.dir, self.flag)

    def create(self) -> Path:
        """Create and lock the directory (after validation); return the staging folder
        every file of this run is written into."""
        try:
            self.dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise UsageError(f"{self.flag} {self.dir}: {exc.strerror or exc}") from None
        self._lock = _lock_directory(self.dir, self.flag)
        for old in self.dir.glob(self.STAGE_PREFIX + "*"):  # a killed run's leftovers
            shutil.rmtree(old, ignore_errors=True)
        self.stage = Path(tempfile.mkdtemp(prefix=self.STAGE_PREFIX, dir=self.dir))
        self.created = True
        return self.stage

    def staged(self, final: Path) -> Path:
        """A temporary path beside ``final`` (a file outside the directory, or the one
        output of a command): written there, renamed to ``final`` by :meth:`commit`."""
        final = Path(final)
        final.parent.mkdir(parents=True, exist_ok=True)
        # the final suffix last: writers that choose a format by it (a GIF) still can
        fd, tmp = tempfile.mkstemp(prefix=f".{final.name}.", suffix=f".partial{final.suffix}",
                                   dir=final.parent)
        os.close(fd)
        self._outside[Path(tmp)] = final
        self.created = True
        return Path(tmp)

    def keep_on_interrupt(self, name: str) -> None:
        """Staged file ``name`` is moved into the directory even when the run is
        interrupted (a partial file whose name cannot be mistaken for a result)."""
        self._keep.append(name)

    def __truediv__(self, name: str) -> Path:
        return (self.stage if self.stage is not None else self.dir) / name

    def final(self, path: Path) -> Path:
        """Where a staged ``path`` ends up."""
        path = Path(path)
        if path in self._outside:
            return self._outside[path]
        if self.stage is not None:
            with contextlib.suppress(ValueError):
                return self.dir / path.relative_to(self.stage)
        return path

    def wrote(self, path: Path) -> Path:
        self.written.append(Path(path))
        return Path(path)

    def commit(self, names: list[str] | None = None) -> None:
        """Move the staged files (or only ``names``) into place and release the lock."""
        if self.stage is not None and self.stage.exists():
            for src in sorted(p for p in self.stage.rglob("*") if not p.is_dir()):
                rel = src.relative_to(self.stage)
                if names is not None and str(rel) not in names:
                    continue
                dst = self.dir / rel
                dst.parent.mkdir(parents=True, exist_ok=True)
                os.replace(src, dst)
                self.committed.append(dst)
        if names is None:
            for name in self.obsolete:
                with contextlib.suppress(FileNotFoundError):
                    (self.dir / name).unlink()
            for tmp, final in list(self._outside.items()):
                if tmp.exists():
                    os.replace(tmp, final)
                    self.committed.append(final)
                del self._outside[tmp]
        self.discard()

    def discard(self) -> None:
        """Remove what this run staged (the earlier run's files stay) and release the lock."""
        if self.stage is not None:
            shutil.rmtree(self.stage, ignore_errors=True)
            self.stage = None
        for tmp in self._outside:
            with contextlib.suppress(OSError):
                tmp.unlink()
        self._outside.clear()
        if self._lock is not None:
            os.close(self._lock)
            self._lock = None

    def interrupted(self) -> None:
        """Keep the partial files named by :meth:`keep_on_interrupt`, drop the rest."""
        if self._keep:
            with contextlib.suppress(OSError):
                self.commit(self._keep)
        self.discard()

    def describe(self) -> str:
        """What is on disk from this run, for the interruption line."""
        if not self.created:
            return "nothing written" + (f" ({self.dir} untouched)" if str(self.dir) != "."
                                        else "")
        done = [str(p) for p in self.committed if p.exists()]
        if done:
            text = "wrote " + ", ".join(done)
        else:
            text = f"nothing written to {self.dir}"  # its earlier files are untouched
        return "; ".join([text, *self.notes])


def _lock_directory(directory: Path, flag: str) -> int | None:
    """An exclusive lock on ``directory`` held while the run writes into it (released
    when the descriptor closes, also when the process dies); UsageError when it is
    taken."""
    try:
        # deferred: fcntl is POSIX only; without it (ImportError) no lock
        import fcntl
    except ImportError:  # not POSIX: the unique staging folder still keeps runs apart
        return None
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise UsageError(f"{flag} {directory}: another run is writing into this directory; "
                         f"wait for it or choose another {flag}") from None
    except OSError:  # a file system without locks
        pass
    return fd


def output_path(flag: str) -> Callable[[str], Path]:
    """Type: an output path (not empty: an empty name would mean the current directory)."""
    def parse(text: str) -> Path:
        if not text.strip():
            raise argparse.ArgumentTypeError(f"{flag} must name a path, got {text!r}")
        return Path(text)
    parse.__name__ = "path"
    return parse


# -- scheduler ---------------------------------------------------------------------------------
SCHEDULER_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")


def check_scheduler_address(address: str) -> None:
    """Raise :class:`UsageError` unless ``address`` looks like ``tcp://host:port``."""
    text = address.strip()
    if text.startswith("inproc://") and len(text) > len("inproc://"):
        return  # a scheduler in this very process (tests, notebooks)
    parts = urlsplit(text)
    if parts.scheme not in SCHEDULER_SCHEMES or "://" not in text:
        raise UsageError(f"--scheduler {address!r}: not a scheduler address; expected "
                         f"SCHEME://HOST:PORT with SCHEME one of {', '.join(SCHEDULER_SCHEMES)}"
                         f" (e.g. tcp://10.0.0.5:8786)")
    try:
        port = parts.port
    except ValueError:
        raise UsageError(f"--scheduler {address!r}: the port must be an integer in "
                         f"1..65535") from None
    if not parts.hostname:
        raise UsageError(f"--scheduler {address!r}: no host name")
    if port is None or not 1 <= port <= 65535:
        raise UsageError(f"--scheduler {address!r}: needs a port in 1..65535 "
                         f"(e.g. {parts.scheme}://{parts.hostname}:8786)")
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        raise UsageError(f"--scheduler {address!r}: unexpected path or query after the port")


def connect_scheduler(address: str, timeout: float = 5.0) -> None:
    """Check that a Dask scheduler answers at ``address`` (the form is checked first);
    raise :class:`UsageError` when dask.distributed is missing or the connection fails."""
    check_scheduler_address(address)
    try:
        # deferred: dask.distributed is optional (pdw-casadi[dask]); only --scheduler needs it
        from distributed import Client
    except ImportError:
        raise UsageError("--scheduler needs dask.distributed: pip install "
                         "'pdw-casadi[dask]'") from None
    quiet = [logging.getLogger(n) for n in ("distributed", "distributed.client",
                                            "distributed.comm", "distributed.core")]
    levels = [lg.level for lg in quiet]
    for lg in quiet:
        lg.setLevel(logging.CRITICAL)
    try:
        client = Client(address.strip(), timeout=f"{timeout}s", set_as_default=False)
    except Exception as exc:  # OSError, TimeoutError, CommClosedError, ...
        reason = one_line(exc) or type(exc).__name__
        raise UsageError(f"--scheduler {address}: cannot connect within {timeout:g} s: "
                         f"{reason}") from None
    finally:
        for lg, level in zip(quiet, levels, strict=True):
            lg.setLevel(level)
    client.close()


# -- running a command -------------------------------------------------------------------------
@contextlib.contextmanager
def user_errors() -> Iterator[None]:
    """Turn the expected user errors raised inside the block into :func:`fail` (one
    ``error:`` line, exit code 2)."""
    try:
        yield
    except USER_ERRORS as exc:
        if isinstance(exc, OSError) and exc.filename is not None:
            fail(f"{exc.filename}: {exc.strerror or exc}")
        fail(exc)


def run(outputs: Outputs | None, body: Callable[[], int]) -> int:
    """Run a command body under the contract (module docstring); its exit code.

    The staged outputs are moved into place when the body returns or finds no gait (its
    files then describe the result) and removed when it fails or is interrupted. A signal
    that a solver swallowed still ends the run as interrupted."""
    with interrupt.handling():
        try:
            return _run(outputs, body)
        except KeyboardInterrupt as exc:
            signum = getattr(exc, "signum", None) or interrupt.requested() or signal.SIGINT
            if outputs is not None:
                outputs.interrupted()
            where = outputs.describe() if outputs is not None else "nothing written"
            print(f"interrupted: {where}", file=sys.stderr, flush=True)
            code = interrupt.EXIT_CODES.get(signum, EXIT_INTERRUPTED)
            if outputs is not None:
                outputs.discard()
            interrupt.exit_at_once(code)
            return code
        finally:
            if outputs is not None:
                outputs.discard()  # nothing left to do after a commit


def _write_error(outputs: Outputs | None, exc: BaseException) -> Path | None:
    """The output file a failed write was writing (None: not a write of this run)."""
    if outputs is None or not outputs.created or not isinstance(exc, OSError):
        return None
    roots = [outputs.dir.resolve(), *(p.parent.resolve() for p in outputs._outside)]
    if exc.filename is not None:
        path = Path(os.path.abspath(exc.filename))
        if not any(path.resolve().is_relative_to(r) for r in roots):
            return None
        return outputs.final(path)
    # pandas and matplotlib drop the name: the file being written is the newest one
    files = [p for p in outputs.stage.rglob("*") if p.is_file()] if outputs.stage else []
    files += [p for p in outputs._outside if p.exists()]
    if not files:
        return outputs.dir
    return outputs.final(max(files, key=lambda p: p.stat().st_mtime_ns))


def _run(outputs: Outputs | None, body: Callable[[], int]) -> int:
    no_gait = None
    try:
        code = body()
    except SystemExit:
        raise
    except KeyboardInterrupt:
        raise
    except NoGait as exc:
        code, no_gait = EXIT_NO_GAIT, exc
    except Exception as exc:
        interrupt.check()  # an exception that stands for a swallowed Ctrl-C
        target = _write_error(outputs, exc)
        if target is not None:
            outputs.discard()
            fail(f"could not write {target}: {exc.strerror or exc}", EXIT_NO_GAIT)
        if isinstance(exc, USER_ERRORS):
            with user_errors():
                raise exc from None
        if os.environ.get("PDW_DEBUG"):
            raise
        if outputs is not None:
            outputs.discard()
        where = outputs.describe() if outputs is not None else "nothing written"
        print(f"error: internal error ({type(exc).__name__}: {one_line(exc)}); {where}. "
              f"This is a bug: please report it (PDW_DEBUG=1 shows the traceback)",
              file=sys.stderr, flush=True)
        return EXIT_NO_GAIT
    interrupt.check()  # the body returned, but a signal arrived on the way: not a result
    if outputs is not None:
        with interrupt.deferred():
            try:
                outputs.commit()
            except OSError as exc:
                outputs.discard()
                fail(f"could not write {outputs.final(Path(exc.filename or outputs.dir))}: "
                     f"{exc.strerror or exc}", EXIT_NO_GAIT)
    if no_gait is not None:
        print(f"no gait: {one_line(no_gait)}", file=sys.stderr, flush=True)
    signum = interrupt.requested()
    if signum is not None:  # arrived while the finished files were moved into place
        where = outputs.describe() if outputs is not None else "nothing written"
        print(f"interrupted: {where}", file=sys.stderr, flush=True)
        return interrupt.EXIT_CODES.get(signum, EXIT_INTERRUPTED)
    return code
