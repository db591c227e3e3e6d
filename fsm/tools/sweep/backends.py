"""Where the runs run: a local process pool (spawn, the default) or a Ray cluster through
``ray.util.multiprocessing.Pool``. Both are a ``multiprocessing.Pool``-like object whose ``imap_unordered``
maps :func:`fsm.tools.sweep.worker.run_one` over the jobs, so there is one code path. Ray is imported only here,
only when asked for (the ``ray`` extra)."""

from __future__ import annotations

import logging
from typing import Any


class BackendError(Exception):
    """The backend cannot start (Ray missing, an unreachable address): said before any run starts."""


def local_pool(processes: int) -> Any:
    """A spawn pool whose workers never see Ctrl-C: SIGINT is blocked while they start (a blocked signal stays
    blocked across exec, so a Ctrl-C while a worker imports raises nothing there) and ignored once they run; the
    parent stops them. A Ctrl-C that arrives meanwhile reaches the parent when it is unblocked."""
    import multiprocessing
    import signal
    from multiprocessing import resource_tracker

    from .worker import init_worker

    resource_tracker.ensure_running()  # first: starting it unblocks SIGINT in this thread again
    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT}) if hasattr(signal, "pthread_sigmask") else None
    try:
        return multiprocessing.get_context("spawn").Pool(processes, initializer=init_worker)
    finally:
        if blocked is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)


def ray_pool(processes: int, address: str | None) -> Any:
    try:
        import ray
        from ray.util.multiprocessing import Pool
    except ImportError:
        raise BackendError("--backend ray needs Ray: pip install 'tral-fsm[ray]'") from None
    from .worker import init_worker

    if address and address != "auto":
        _reachable(address)
    import signal
    import threading

    main = threading.current_thread() is threading.main_thread()
    sigterm = signal.getsignal(signal.SIGTERM) if main else None
    try:
        if not ray.is_initialized():
            if address:
                ray.init(address=address, log_to_driver=False, logging_level=logging.ERROR)
            else:
                ray.init(num_cpus=processes, include_dashboard=False, log_to_driver=False, logging_level=logging.ERROR,
                         object_store_memory=100 * 1024 * 1024)
    except Exception as exc:  # ConnectionError, TimeoutError, ValueError for a malformed address, ...
        where = f"at {address}" if address else "locally"
        raise BackendError(f"cannot start or reach a Ray cluster {where}: {' '.join(str(exc).split())[:300]}") from None
    finally:
        if main and sigterm is not None:  # ray.init makes SIGTERM exit at once; the sweep's own handler stops cleanly
            signal.signal(signal.SIGTERM, sigterm)
    return Pool(processes, initializer=init_worker)


def _reachable(address: str, timeout: float = 3.0) -> None:
    """Refuse an address nobody listens on at once (Ray itself retries for minutes)."""
    import socket

    host, _, port = address.removeprefix("ray://").rpartition(":")
    try:
        port_number = int(port)
    except ValueError:
        raise BackendError(f"--address {address}: write HOST:PORT of the Ray head (e.g. 10.0.0.5:6379)") from None
    try:
        with socket.create_connection((host or "127.0.0.1", port_number), timeout=timeout):
            pass
    except OSError as exc:
        raise BackendError(f"cannot start or reach a Ray cluster at {address}: {exc.strerror or exc}") from None


def shutdown_ray() -> None:
    import sys

    ray = sys.modules.get("ray")
    if ray is not None and ray.is_initialized():
        ray.shutdown()
