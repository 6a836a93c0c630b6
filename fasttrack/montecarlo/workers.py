"""Where batches of runs execute: this process, a pool of local worker processes kept between
calls, or a Dask cluster."""
import ast
import collections
import contextlib
import multiprocessing
import multiprocessing.connection
import os
import pickle
import sys
import traceback

from .._validate import count
from .trial import _run_batch
from .results import RunFailure

__all__ = ["local_cluster"]

_INSTALL = "pip install 'fasttrack[distributed]'"


def _serialise(scenario, make_filter, metrics, mapping, cutoff, threads):
    """The pickled payload of the tasks (cloudpickle when installed, so that lambdas and
    functions defined in ``__main__`` travel too)."""
    try:
        import cloudpickle as pickler
    except ImportError:
        pickler = pickle
    try:
        return pickler.dumps((scenario, make_filter, metrics, mapping, cutoff, threads))
    except Exception as error:
        raise TypeError(f"scenario and make_filter must be picklable to run in other "
                        f"processes (define them at module level, install cloudpickle, or "
                        f"pass processes=1 to run in this process): {error}") from error


def check_main_guard():
    """Raise RuntimeError if this call comes from top-level code of a script that is not
    under ``if __name__ == "__main__":``: spawned worker processes import the script again
    and would run the call again, and die starting processes of their own."""
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if path is None or not str(path).endswith(".py") or not os.path.exists(path):
        return  # an interactive session, python -c, a notebook: nothing is re-imported
    frame = sys._getframe(1)
    while frame is not None and not (frame.f_globals is vars(main)
                                     and frame.f_code.co_name == "<module>"):
        frame = frame.f_back
    if frame is None:
        return
    line = frame.f_lineno
    try:
        with open(path) as script:
            tree = ast.parse(script.read())
    except (OSError, SyntaxError):
        return
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and _is_main_test(node.test) \
                and node.body[0].lineno <= line <= node.body[-1].end_lineno:
            return
    raise RuntimeError(
        f"run_trials with worker processes was called from the top level of {path} (line "
        f"{line}) outside an 'if __name__ == \"__main__\":' block: each worker process "
        f"imports the script again and would run it again. Put the script's top-level work "
        f"under that guard, or pass processes=1 to run in this process.")


def _is_main_test(test):
    """Whether an ``if`` test is ``__name__ == "__main__"`` (either way round)."""
    if not (isinstance(test, ast.Compare) and len(test.ops) == 1
            and isinstance(test.ops[0], ast.Eq)):
        return False
    sides = [test.left, test.comparators[0]]
    names = [s for s in sides if isinstance(s, ast.Name) and s.id == "__name__"]
    values = [s for s in sides if isinstance(s, ast.Constant) and s.value == "__main__"]
    return len(names) == 1 and len(values) == 1


def _local_cores():
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


class _Worker:
    """One spawned worker process and the pipe it takes tasks from."""

    def __init__(self, context):
        self.connection, child = context.Pipe()
        self.process = context.Process(target=_serve, args=(child,), daemon=True)
        self.process.start()
        child.close()

    def stop(self):
        self.connection.close()
        if self.process.is_alive():
            self.process.terminate()
        self.process.join()


def _serve(connection):
    """A worker's loop: run each ``(payload, batch)`` task received, send back
    ``("ok", result)`` or, if the batch could not run at all, ``("error", message)``."""
    while True:
        try:
            payload, batch = connection.recv()
        except (EOFError, OSError):
            return
        try:
            reply = ("ok", _run_batch(payload, batch))
        except Exception as error:
            reply = ("error", f"{type(error).__name__}: {error}\n{traceback.format_exc()}")
        connection.send(reply)


class _Pool:
    """``processes`` spawned worker processes, each running one batch at a time, kept
    between calls so that their kernels stay compiled (they end with the interpreter).

    Each batch is sent to one worker, so a worker that dies costs only the batch it was
    running: that batch is charged one attempt and queued again, a new worker takes the
    dead one's place, and the other workers go on.
    """

    def __init__(self, processes):
        self.context = multiprocessing.get_context("spawn")
        self.workers = [_Worker(self.context) for _ in range(processes)]

    def run(self, payload, batches, max_retries):
        """Yield each batch's result; a batch whose worker died more than ``max_retries``
        times has all its runs failed."""
        queue = collections.deque(range(len(batches)))
        attempts = [0] * len(batches)
        running = {}  # worker -> batch index
        try:
            while queue or running:
                for worker in list(self.workers):
                    if queue and worker not in running:
                        i = queue.popleft()
                        running[self._send(worker, payload, batches[i])] = i
                waiting = {w.connection: w for w in running}
                waiting.update({w.process.sentinel: w for w in running})
                done = {waiting[ready] for ready in multiprocessing.connection.wait(waiting)}
                for worker in done:
                    i = running.pop(worker)
                    reply = self._reply(worker)
                    if reply is not None:
                        yield batches[i], _result(batches[i], reply)
                        continue
                    attempts[i] += 1
                    if attempts[i] > max_retries:
                        yield batches[i], _lost(batches[i], f"the worker process died "
                                                            f"{attempts[i]} times")
                    else:
                        queue.appendleft(i)
        finally:  # an interrupted call leaves no work behind: its workers are replaced
            for worker in running:
                self._replace(worker)

    def _send(self, worker, payload, batch):
        """Send the task to ``worker``, or to its replacement if it has died while idle;
        returns the worker that took it."""
        try:
            worker.connection.send((payload, batch))
            return worker
        except (BrokenPipeError, OSError):
            worker = self._replace(worker)
            worker.connection.send((payload, batch))
            return worker

    def _reply(self, worker):
        """The worker's reply, or None if it died (it is then replaced)."""
        try:
            if worker.connection.poll():
                return worker.connection.recv()
        except (EOFError, OSError):
            pass
        self._replace(worker)
        return None

    def _replace(self, worker):
        """Stop ``worker`` and start a new one in its place; returns the new one."""
        worker.stop()
        new = _Worker(self.context)
        self.workers[self.workers.index(worker)] = new
        return new

    def shutdown(self):
        for worker in self.workers:
            worker.stop()
        self.workers = []


def _result(batch, reply):
    """A batch's result from a worker's reply: an error fails every run of the batch."""
    status, value = reply
    if status == "ok":
        return value
    message, _, details = value.partition("\n")
    return [], [RunFailure(run, seed, message, details) for run, seed in batch]


_pool = {}


def _local_pool(processes):
    """The :class:`_Pool` of ``processes`` workers (a pool of another size is shut down)."""
    if processes not in _pool:
        for old in _pool.values():
            old.shutdown()
        _pool.clear()
        _pool[processes] = _Pool(processes)
    return _pool[processes]


def _run_local(payload, batches, processes, max_retries):
    """Yield each batch's result, in this process or in the pool of worker processes."""
    if processes == 1:
        for batch in batches:
            yield batch, _run_batch(payload, batch)
        return
    yield from _local_pool(processes).run(payload, batches, max_retries)


def _lost(batch, reason):
    """The result of a batch that could not be run: every run failed with ``reason``."""
    return [], [RunFailure(run, seed, f"WorkerLost: {reason}", "") for run, seed in batch]


def _run_dask(client, payload, batches):
    """Yield each batch's result from ``client``'s cluster."""
    try:
        from distributed import as_completed
        from distributed.scheduler import KilledWorker
    except ImportError:
        raise ImportError(f"run_trials with a client needs Dask: {_INSTALL}") from None
    futures = {client.submit(_run_batch, payload, batch, pure=False): batch
               for batch in batches}
    try:
        for future in as_completed(futures):
            batch = futures[future]
            try:
                result = future.result()
            except KilledWorker as error:
                result = _lost(batch, f"Dask gave up on the task: {error}")
            yield batch, result
    finally:  # an interrupted call leaves no queued work behind
        client.cancel(list(futures))


@contextlib.contextmanager
def local_cluster(n_workers=None):
    """A ``distributed.Client`` on a new Dask ``LocalCluster`` of ``n_workers`` worker
    processes (default: the usable cores) with one thread each, closed on exit::

        with local_cluster(2) as client:
            results = run_trials(scenario, make_filter, 1000, client=client)

    Parameters
    ----------
    n_workers : int, optional
        Number of worker processes, >= 1 (default: the usable cores).
    """
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise ImportError(f"a Dask cluster needs Dask: {_INSTALL}") from None
    n_workers = count(n_workers, "n_workers", default=_local_cores())
    with LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        yield client


@contextlib.contextmanager
def _client(client):
    """The ``distributed.Client`` given, or one connected to the scheduler address given
    (closed on exit)."""
    if not isinstance(client, str):
        yield client
        return
    try:
        from distributed import Client
    except ImportError:
        raise ImportError(f"connecting to a Dask scheduler needs Dask: {_INSTALL}") from None
    with Client(client) as connected:
        yield connected
