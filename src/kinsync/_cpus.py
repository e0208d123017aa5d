"""How many CPUs this process may use."""

from __future__ import annotations

import os

__all__ = ["usable_cpus"]


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity where the system has one, e.g. Linux).

    Under ``taskset`` or a container's CPU set this is fewer than the machine's CPUs,
    which `os.cpu_count` gives.
    """
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return os.cpu_count() or 1
