"""Where the Dask tasks of ``sweep``, ``tune`` and ``optimum`` run, and how the client follows them:
one way for the three commands.

- ``workers`` (default: one per core): an embedded ``dask.distributed.LocalCluster`` of that many
  worker processes, started and stopped by the command. Processes, not threads: the FMUs and the
  cores run Python, so threads would share one GIL. No dashboard: its HTTP server listens on a free
  port of this machine only, so a second command (or any program on port 8787) is no warning.
- ``scheduler="tcp://HOST:PORT"``: an existing cluster (``dask scheduler`` on one machine, ``dask
  worker tcp://HOST:8786 --nthreads 1`` on each machine, each with the same sotc-cosim installed).

Each command's temporary files go into a scratch folder named after this process
(``orchestration.scratch``): removed at the end, and by the next command if this one was killed
before it could clean up.
"""
from __future__ import annotations

import logging
import os
import shutil
import signal
import threading
import time
from dataclasses import dataclass
from typing import Any, Callable

from distributed import WorkerPlugin

from orchestration.outputs import private_folder
from orchestration.run import interrupt
from orchestration.run.scenario import ScenarioError
from orchestration.scratch import remove_stale, scratch_name

POLL_S = 0.05  # how often the client looks for finished tasks and for Ctrl-C


def worker_count(workers: int | None) -> int:
    """The local cluster's worker processes: ``workers``, else one per core."""
    return workers or os.cpu_count() or 1


def where(scheduler: str | None, workers: int | None) -> str:
    """Where the tasks run, for the command's first line."""
    return scheduler or f"a local Dask cluster of {worker_count(workers)} worker processes"


def scratch_folder() -> str:
    """A new scratch folder of this process under the private ``scratch`` folder (its name); the
    folders of this host's processes that are gone are removed first."""
    remove_stale(private_folder("scratch"))  # left by a command killed before it could clean up
    name = scratch_name()
    private_folder("scratch", name)
    return name


@dataclass
class Cluster:
    client: Any  # distributed.Client
    local: Any  # the LocalCluster this command started, or None on an existing scheduler
    scratch: str  # this command's scratch folder (a name under the private ``scratch`` folder)


CONNECT_TIMEOUT = "10s"  # how long a --scheduler is tried (distributed retries a refused connection until then)


def open_client(scheduler: str | None, workers: int | None) -> Cluster:
    """A client of the scheduler at ``scheduler`` (``ScenarioError`` naming ``--scheduler`` if there
    is none), or of a local cluster whose workers keep their files in this command's scratch folder."""
    scratch = scratch_folder()
    try:
        return Cluster(*_connect(scheduler, workers, scratch), scratch)
    except BaseException:  # nothing started: the scratch folder goes at once
        shutil.rmtree(private_folder("scratch") / scratch, ignore_errors=True)
        raise


def _connect(scheduler: str | None, workers: int | None, scratch: str) -> tuple[Any, Any]:
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            return Client(scheduler, timeout=CONNECT_TIMEOUT), None
        except OSError as exc:
            raise ScenarioError(f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({exc})") from None
        except (ValueError, TypeError) as exc:  # not an address: no port, a bad port, an unknown protocol
            raise ScenarioError(f"--scheduler {scheduler}: not a Dask scheduler address such as tcp://host:8786 "
                                f"({exc})") from None
    import dask

    files = str(private_folder("scratch", scratch, "dask"))
    dask.config.set({"temporary-directory": files})  # the scheduler's and workers' lock files go there too
    local = LocalCluster(n_workers=worker_count(workers), threads_per_worker=1, processes=True,
                         dashboard_address=None, scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                         silence_logs=logging.ERROR, local_directory=files)
    client = Client(local)
    client.register_plugin(IgnoreSigint())
    return client, local


def follow(futures: list, done: Callable[[Any], list | None], tick: Callable[[], None] | None = None,
           poll_s: float = POLL_S) -> bool:
    """Hand each future to ``done`` as it finishes (finished or failed), and follow the futures it returns too
    (work that could start only then); call ``tick`` after every look; True if Ctrl-C stopped the following
    first (the CLI defers SIGINT to a flag, ``orchestration.run.interrupt``; a library caller gets
    ``KeyboardInterrupt``)."""
    from distributed import as_completed

    pending = as_completed(futures)
    try:
        while not pending.is_empty():
            if interrupt.requested():
                return True
            ready = pending.next_batch(block=False)
            for future in ready:
                more = done(future)
                if more:
                    pending.update(more)
            if tick is not None:
                tick()
            if not ready:
                time.sleep(poll_s)
    except KeyboardInterrupt:
        return True
    return False


class IgnoreSigint(WorkerPlugin):
    """On local workers (also those the nanny restarts): the terminal's Ctrl-C reaches the whole
    process group, but a worker must not be interrupted inside an FMU call; the client stops the
    local workers itself."""

    name = "sotc-cosim-ignore-sigint"

    def setup(self, worker) -> None:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)


def shutdown(cluster: Cluster | None, futures: list, interrupted: bool) -> None:
    """Stop promptly, quietly, and remove the scratch folder: cancel what is pending and, after Ctrl-C (or an
    error), end the local workers' processes (a task in the middle of a long run would otherwise finish
    first). On an existing cluster a task already running finishes there unseen.

    Closing is quiet: connections closing while the cluster stops are expected, and distributed logged
    some of them with a ``CommClosedError`` traceback on the user's terminal (1 small sweep in 5), from this
    process (client, scheduler, nannies) and from the workers, which are told first (``quiet``)."""
    if cluster is None:
        return
    disabled = logging.root.manager.disable
    try:
        if interrupted:
            cluster.client.cancel(futures, force=True)
            logging.disable(logging.CRITICAL)
            _kill_local_workers(cluster.local)
        elif cluster.local is not None:
            try:
                cluster.client.run(quiet)  # the workers this command started, before they are told to close
            except Exception:  # a worker that cannot be reached is closed all the same
                pass
        logging.disable(logging.CRITICAL)
        cluster.client.close(timeout=10)
        if cluster.local is not None:
            cluster.local.close(timeout=10)
    finally:
        logging.disable(disabled)
        shutil.rmtree(private_folder("scratch") / cluster.scratch, ignore_errors=True)


def quiet() -> None:
    """No more log records in this process (a worker about to be closed)."""
    logging.disable(logging.CRITICAL)


def _kill_local_workers(local) -> None:
    for nanny in list(local.workers.values()) if local is not None else []:
        pid = getattr(getattr(getattr(nanny, "process", None), "process", None), "pid", None)
        if pid:
            try:
                os.kill(pid, signal.SIGKILL)  # a worker process this command started
            except ProcessLookupError:
                pass
