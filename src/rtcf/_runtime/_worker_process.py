"""The supervisor's side of one worker process: start, the control channel, death.

:class:`WorkerProcess` starts ``python -m rtcf._runtime._worker``, hands it the
segments every worker needs from its start (the control words, /clock's mailbox,
the log ring) and sends it commands over a Unix socket between runs, draining what
the worker writes while it waits. It owns every segment of its worker: anonymous
memory (memfd) handed over as a file descriptor, so there is no name that could be
left behind whatever way either process ends (SIGKILL included). A worker that dies,
or a hook that does not return within hook_timeout, is noticed within a polling
interval and said as a :class:`WorkerDied`: which worker, how, and what it ran.
"""

from __future__ import annotations

import os

from .._core._errors import RtcfError

POLL_S = 0.01  # how often the supervisor drains while it waits for the worker


class WorkerDied(RtcfError):
    """The worker process ended without being asked to."""


def worker_env() -> dict[str, str]:
    env = dict(os.environ)
    # the worker must find this very rtcf even when it is not installed
    src = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env["PYTHONPATH"] = os.pathsep.join(p for p in (src, env.get("PYTHONPATH", "")) if p)
    # a component that imports numpy must not start BLAS worker threads beside the loop
    for key in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        env.setdefault(key, "1")
    return env


def keep_off_cpus(worker_cpus: list[int]) -> None:
    """Move the supervisor off the worker's CPUs when that leaves it somewhere to run."""
    try:
        mine = os.sched_getaffinity(0)
        rest = mine - set(worker_cpus)
        if worker_cpus and rest and rest != mine:
            os.sched_setaffinity(0, rest)
    except OSError:
        pass

