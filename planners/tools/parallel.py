"""Where independent work runs: in this process, on a local process pool, or on a Ray cluster.

One interface for every parallel part of the library (the comparison's runs, DAgger's rollouts and
validation)::

    backend = make_backend("local", processes=2)        # or make_backend("ray", address="auto")
    results = backend.map(fn, tasks, context=shared)    # [fn(task, shared) for task in tasks], in order

``fn`` must be a module-level function (workers import it by name). ``context`` is what every task
needs and no task should carry (loaded maps, a policy's weights): it goes to each worker once, through a
pool initializer locally and Ray's object store on Ray, never once per task. Tasks travel in chunks,
so runs of a few milliseconds are not dominated by scheduling. Results never depend on the backend:
``fn`` gets the same task and context wherever it runs, and results come back in task order.

The local backend needs nothing beyond the standard library; Ray is the optional extra
``pip install -e ".[distributed]"``. On Ray a task whose worker dies is retried (``max_retries``), so a
killed worker loses only its in-flight chunks.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from typing import Any, Protocol

#: The names ``make_backend`` accepts.
BACKENDS = ("local", "ray")

# BLAS/OpenMP pools in every worker would fight over the cores the workers are timing runs on; the
# variables must be set before a worker imports numpy
_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


class Backend(Protocol):
    """Runs ``fn(task, context)`` for every task and returns the results in task order."""

    workers: int

    def map(self, fn: Callable[[Any, Any], Any], tasks: Sequence, *, context: Any = None,
            chunksize: int | None = None, progress: bool = False, desc: str = "tasks",
            on_result: Callable[[int, Any], None] | None = None) -> list: ...

    def close(self) -> None: ...


def default_chunksize(n_tasks: int, workers: int) -> int:
    """About 16 chunks per worker: few enough that scheduling is negligible, enough to balance load."""
    return max(1, math.ceil(n_tasks / (16 * max(workers, 1))))


def make_backend(name: str = "local", *, processes: int | None = None, address: str | None = None,
                 worker_init: Callable[[], None] | None = None) -> Backend:
    """A backend by name.

    Args:
        name: ``"local"`` (this process when ``processes <= 1``, else a pool of that many processes) or
            ``"ray"`` (a local Ray instance with ``processes`` CPUs, or the cluster at ``address``).
        processes: Local workers; default ``os.cpu_count()``. On a Ray cluster the cluster decides.
        address: Ray only: the cluster to join (``"auto"``, ``"ray://host:10001"``, ...).
        worker_init: Called once in each worker before its first task (e.g. to cap torch's threads).
    """
    if name == "local":
        if address is not None:
            raise ValueError("--address is for the ray backend; the local backend runs on this machine")
        return LocalBackend(processes or os.cpu_count() or 1, worker_init)
    if name == "ray":
        return RayBackend(address=address, processes=processes, worker_init=worker_init)
    raise ValueError(f"unknown backend {name!r}; choose from {', '.join(BACKENDS)}")


def add_backend_arguments(ap, *, processes: int | None, backend_help: str, processes_help: str) -> None:
    """``--backend``, ``--processes`` and ``--address`` on an ``argparse`` parser, as every script spells them."""
    ap.add_argument("--backend", choices=BACKENDS, default="local", help=backend_help)
    ap.add_argument("--processes", type=int, default=processes, help=processes_help)
    ap.add_argument("--address", default=None, help="ray backend: the cluster to join (default: start a local one)")


def check_backend_arguments(ap, args) -> None:
    """Refuse, through ``ap.error``, a ``--processes`` below 1 and an ``--address`` without ``--backend ray``."""
    if args.processes < 1:
        ap.error(f"--processes must be at least 1, got {args.processes}")
    if args.address is not None and args.backend != "ray":
        ap.error("--address needs --backend ray")


# --- local: this process, or a spawned pool -------------------------------------------------------

_LOCAL: dict = {}  # in a pool worker: the context and the function the pool serves


def _pool_init(fn, context, worker_init) -> None:
    import signal

    # Ctrl-C reaches the whole process group: the parent stops the pool, the workers stay quiet
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if worker_init is not None:
        worker_init()
    _LOCAL["fn"], _LOCAL["context"] = fn, context


def _pool_chunk(chunk):
    return [_LOCAL["fn"](task, _LOCAL["context"]) for task in chunk]


class WorkerDied(RuntimeError):
    """A process of the local pool ended while its tasks were unfinished (the pool would wait for them forever)."""


#: Seconds without a result after which the local pool checks that its workers are the ones it started.
WATCH_SECONDS = 2.0


def _watched(results, workers: int, every: float = WATCH_SECONDS):
    """The results of ``results`` (a pool's ``imap`` of chunks), raising ``WorkerDied`` once a worker was replaced.

    ``multiprocessing.Pool`` replaces a worker that exits and loses the tasks it held, so a worker that dies (killed
    for memory, or a script re-run by the spawn start method that fails at its top level) would leave the caller
    waiting forever. The pool's workers are this process's children; whenever ``every`` seconds pass without a
    result, a child that was not among them means one of them was replaced.
    """
    import multiprocessing as mp

    started = {p.pid for p in mp.active_children()}
    while True:
        try:
            yield from results.next(timeout=every)
        except StopIteration:
            return
        except mp.TimeoutError:
            now = {p.pid for p in mp.active_children()}
            if now - started:
                raise WorkerDied(
                    f"a worker process of the local pool ({workers} processes) ended before its tasks were done. If a "
                    "script starts this with more than one process, its top-level code must run under `if __name__ "
                    "== '__main__':` (the spawn start method runs the script again in each worker); a worker killed "
                    "for memory ends the same way (use fewer processes)") from None


class LocalBackend:
    """This process (``processes <= 1``) or a pool of fresh ("spawn") processes on this machine.

    A worker that dies stops the map with ``WorkerDied`` rather than leaving it waiting.
    """

    def __init__(self, processes: int = 1, worker_init: Callable[[], None] | None = None) -> None:
        self.workers = max(1, int(processes))
        self.worker_init = worker_init
        self._init_done = False

    def map(self, fn, tasks, *, context=None, chunksize=None, progress=False, desc="tasks", on_result=None) -> list:
        """``fn(task, context)`` for every task, in order; ``on_result(index, result)`` as each one arrives.

        An exception in the caller (Ctrl-C, a signal turned into one) terminates the pool's workers.
        """
        from tqdm.auto import tqdm

        tasks = list(tasks)
        if self.workers <= 1 or len(tasks) <= 1:
            if self.worker_init is not None and not self._init_done:
                self.worker_init()
                self._init_done = True
            out = []
            for i, t in enumerate(tqdm(tasks, desc=desc, disable=not progress)):
                out.append(fn(t, context))
                if on_result is not None:
                    on_result(i, out[-1])
            return out
        import multiprocessing as mp

        ctx = mp.get_context("spawn")  # fresh interpreters: no inherited locks or thread pools
        saved = {k: os.environ.get(k) for k in _THREAD_VARS}
        os.environ.update(dict.fromkeys(_THREAD_VARS, "1"))
        try:
            # the context is pickled once per worker (initializer), not once per task
            with ctx.Pool(self.workers, initializer=_pool_init, initargs=(fn, context, self.worker_init)) as pool:
                size = chunksize or 4
                chunks = [tasks[i:i + size] for i in range(0, len(tasks), size)]
                it = _watched(pool.imap(_pool_chunk, chunks), self.workers)
                out = []
                for i, r in enumerate(tqdm(it, total=len(tasks), desc=desc, disable=not progress)):
                    out.append(r)
                    if on_result is not None:
                        on_result(i, r)
                return out
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v

    def close(self) -> None:
        pass


# --- Ray ------------------------------------------------------------------------------------------

_RAY: dict = {}  # in a Ray worker: the contexts fetched so far, by object id, and whether init ran


def _ray_chunk(fn, chunk, boxed_ref, worker_init):
    # the reference arrives inside a list so Ray does not resolve it per task: each worker fetches
    # (zero-copy for numpy arrays) and keeps the context once
    import ray

    ref = boxed_ref[0]
    key = ref.hex()
    if key not in _RAY.get("contexts", {}):
        if worker_init is not None and not _RAY.get("init_done"):
            worker_init()
            _RAY["init_done"] = True
        _RAY["contexts"] = {key: ray.get(ref)}  # the newest map's context only: older ones are done
    context = _RAY["contexts"][key]
    return [fn(t, context) for t in chunk]


class RayBackend:
    """Tasks as Ray tasks on a local instance (``address=None``) or on the cluster at ``address``."""

    def __init__(self, address: str | None = None, processes: int | None = None,
                 worker_init: Callable[[], None] | None = None, max_retries: int = 3) -> None:
        try:
            import ray
        except ImportError as exc:
            raise ImportError('the ray backend needs Ray: pip install -c constraints.txt -e ".[distributed]"') from exc
        self._ray = ray
        self._started = not ray.is_initialized()
        if self._started:
            kwargs = dict(include_dashboard=False, log_to_driver=False, configure_logging=False)
            if address is None:
                # a local instance: only what this machine can do, on loopback
                kwargs.update(num_cpus=processes or os.cpu_count() or 1, _node_ip_address="127.0.0.1")
            ray.init(address=address, **kwargs)
        self.workers = max(1, int(ray.cluster_resources().get("CPU", 1)))
        self.worker_init = worker_init
        self._task = ray.remote(num_cpus=1, max_retries=max_retries)(_ray_chunk)

    def map(self, fn, tasks, *, context=None, chunksize=None, progress=False, desc="tasks", on_result=None) -> list:
        """As ``LocalBackend.map``; ``on_result`` is called chunk by chunk, in the order chunks finish."""
        from tqdm.auto import tqdm

        ray = self._ray
        tasks = list(tasks)
        if not tasks:
            return []
        size = chunksize or default_chunksize(len(tasks), self.workers)
        ref = ray.put(context)  # once, in the object store; workers fetch it by reference
        chunks = [tasks[i : i + size] for i in range(0, len(tasks), size)]
        futures = [self._task.remote(fn, c, [ref], self.worker_init) for c in chunks]
        with tqdm(total=len(tasks), desc=desc, disable=not progress) as bar:
            pending = list(futures)
            first = {f.hex(): i * size for i, f in enumerate(futures)}
            sizes = {f.hex(): len(c) for f, c in zip(futures, chunks, strict=True)}
            while pending:  # what finished in the last moment, not one at a time: wait() scans all it is given
                done, pending = ray.wait(pending, num_returns=len(pending), timeout=0.2)
                bar.update(sum(sizes[f.hex()] for f in done))
                if on_result is not None:
                    for f in done:
                        for j, r in enumerate(ray.get(f)):
                            on_result(first[f.hex()] + j, r)
        out = []
        for part in ray.get(futures):
            out.extend(part)
        return out

    def close(self) -> None:
        if self._started and self._ray.is_initialized():
            self._ray.shutdown()
