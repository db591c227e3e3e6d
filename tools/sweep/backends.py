"""Where the runs run: a local process pool (spawn, the default) or a Ray cluster through
``ray.util.multiprocessing.Pool``. Both are a ``multiprocessing.Pool``-like object whose ``imap_unordered``
maps :func:`fsm.tools.sweep.worker.run_one` over the jobs, so there is one code path. Ray is imported only here,
only when asked for (the ``ray`` extra)."""

from __future__ import annotations

from typing import Any


class BackendError(Exception):
    """The backend cannot start (Ray missing, an unreachable address): said before any run starts."""


def local_pool(processes: int) -> Any:
    import multiprocessing

    from .worker import init_worker

    return multiprocessing.get_context("spawn").Pool(processes, initializer=init_worker)


def ray_pool(processes: int, address: str | None) -> Any:
    try:
        import ray
        from ray.util.multiprocessing import Pool
    except ImportError:
        raise BackendError("--backend ray needs Ray: pip install 'tral-fsm[ray]'") from None
    from .worker import init_worker

    if address and address != "auto":
        _reachable(address)
    try:
        if not ray.is_initialized():
            if address:
                ray.init(address=address, log_to_driver=False, logging_level="ERROR")
            else:
                ray.init(num_cpus=processes, include_dashboard=False, log_to_driver=False, logging_level="ERROR",
                         object_store_memory=100 * 1024 * 1024)
    except Exception as exc:  # ConnectionError, TimeoutError, ValueError for a malformed address, ...
        where = f"at {address}" if address else "locally"
        raise BackendError(f"cannot start or reach a Ray cluster {where}: {' '.join(str(exc).split())[:300]}") from None
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
