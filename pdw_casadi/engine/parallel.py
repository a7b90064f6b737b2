"""Independent tasks on a process pool or a Dask cluster, results in input order.

:func:`map_tasks` is the one place that decides where work runs: in this process
(``workers <= 1``), on a local process pool (``workers > 1``), or on a Dask cluster
(``scheduler`` = the address of a ``dask.distributed`` scheduler, e.g.
``tcp://10.0.0.5:8786``). The results come back in the order of ``items`` whatever the
backend, and each task is a pure function of its item, so a serial, pooled and distributed
run give identical results. Sweeps (grid points, continuation legs) and the compliance-fit
multistart use it.

``fn`` and the items must be picklable: a module-level function, not a lambda. Pool workers
are forked and inherit the walker's CasADi functions already loaded; Dask workers load the
compiled libraries from ``$PDW_CACHE`` (point it at a shared directory on a cluster, or
each worker compiles once).
"""

from __future__ import annotations

import importlib
import multiprocessing
import signal
import sys
import threading
from collections.abc import Callable, Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")
R = TypeVar("R")


def _pool_context():
    # fork (Linux): a worker inherits the walker's CasADi functions already loaded in the
    # parent instead of loading them again (several seconds per process for the 6-link
    # walker); other platforms cannot fork safely and use their default start method.
    if sys.platform.startswith("linux"):
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context()


def map_tasks(fn: Callable[[T], R], items: Iterable[T], workers: int = 1,
              scheduler: str | None = None, ordered: bool = True) -> Iterator[R]:
    """Yield ``fn(item)`` for every item, in input order, as soon as each is available.

    Args:
        fn: a picklable function of one item.
        items: the task inputs.
        workers: processes of the local pool; 1 (or fewer) runs in this process.
        scheduler: address of a Dask scheduler; when given, the tasks run on that cluster
            and ``workers`` is ignored (the cluster has its own).
        ordered: False yields each result as soon as its task ends, in completion order
            (the caller matches results to items, e.g. by an id the result carries): a
            consumer that saves every result at once then keeps all finished work.

    An exception raised by a task is re-raised here, when its result is reached.
    """
    items = list(items)
    if not items:
        return
    if scheduler is not None:
        yield from _dask_map(fn, items, scheduler, ordered)
    elif workers > 1 and len(items) > 1:
        # a multiprocessing pool, not concurrent.futures: terminate() stops the workers at
        # once (Ctrl-C, a failed task, the consumer stopping) without tracebacks; the
        # workers ignore Ctrl-C themselves, the parent stops them. chunksize 1: a task is
        # handed out only when a worker is free (a worker never holds queued tasks)
        pool = _pool_context().Pool(processes=min(workers, len(items)),
                                    initializer=_ignore_sigint)
        done = False
        try:
            if ordered:
                yield from pool.imap(fn, items)
            else:
                yield from pool.imap_unordered(fn, items, chunksize=1)
            done = True
        finally:
            _shut_down(pool, done)
    else:
        for item in items:
            yield fn(item)


def _shut_down(pool, done: bool) -> None:
    """End ``pool``: after all its tasks, close and join (the workers leave on the task
    handler's sentinels); otherwise (an error, Ctrl-C, the consumer stopping) terminate.
    ``Pool.terminate()`` after finished work can hang for good: it kills the workers
    while the task handler still sends them sentinels (CPython issues 78178 and 96995;
    one test run in several hundred hung here with the pool's context manager)."""
    if not done:
        pool.terminate()
        return
    try:
        pool.close()
        pool.join()
    except BaseException:  # Ctrl-C while the workers leave
        pool.terminate()
        raise


def _ignore_sigint() -> None:
    """A pool worker's signals: Ctrl-C is the parent's to handle, and SIGTERM (the pool's
    terminate()) ends the worker as the default does: a forked worker would otherwise keep
    the command's handler, which raises, and print a traceback while it exits."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _dask_map(fn, items, scheduler: str, ordered: bool = True):
    # deferred: Dask is optional (pdw-casadi[dask]); only a run with a scheduler needs it
    from dask.distributed import Client, as_completed

    with Client(scheduler, set_as_default=False) as client:
        # pure=False: identical items are still separate tasks (no result sharing surprises)
        futures = client.map(fn, items, pure=False)
        try:
            for fut in (futures if ordered else as_completed(futures, loop=client.loop)):
                yield fut.result()
        finally:  # the consumer stopped (Ctrl-C, an error): the cluster drops the rest
            client.cancel(futures)


class ImportAhead:
    """A module imported on a background thread while this one computes.

    The fit's symbolic set-up (CasADi building, differentiating and loading functions)
    runs in C with the interpreter's lock released, about a second per process; a module
    needed only at the end (the report's plotting, a third of a second of imports) is
    imported in those gaps. :meth:`module` waits for it (or imports it here, if the
    thread failed), so the result is the same module either way.
    """

    def __init__(self, name: str):
        self.name = name
        # not a daemon: an interpreter that exits (an error before the report) waits for
        # the import to finish instead of tearing it down half done
        self._thread = threading.Thread(target=self._run, name=f"import {name}")
        self._thread.start()

    def _run(self) -> None:
        try:
            importlib.import_module(self.name)
        except Exception:  # noqa: BLE001 - imported again (and raised) by module()
            pass

    def module(self):
        """The module (imported by now)."""
        self._thread.join()
        return importlib.import_module(self.name)
