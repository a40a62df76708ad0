"""Ray for the sweeps' cells and the training runs' workers: an address checked (its form, and
that a head answers there), Ray imported (the extra ``sweep``; a :class:`RayUnavailableError`
without it), and a cluster joined or a local instance started. Nothing here imports Ray until it
is called."""

from __future__ import annotations

import os
import re
import socket
from types import ModuleType

#: The address of a new Ray instance on this machine (``ray.init(address="local")``).
LOCAL = "local"
#: The address of the cluster this machine joined with ``ray start`` (Ray finds its head).
AUTO = "auto"
#: What an address is: the spellings :func:`check_address` takes.
ADDRESS_FORMS = f"{AUTO}, {LOCAL} or HOST:PORT (a Ray head)"
#: A head's address: a host name or IP (no spaces, colons or slashes), a port; ``ray://`` for
#: Ray Client.
HEAD = re.compile(r"(ray://)?[A-Za-z0-9._\-\[\]]+:(\d{1,5})")
#: The interface of every service of a local instance.
LOOPBACK = "127.0.0.1"
#: s a head's port has to accept a connection: ``ray.init`` itself waits for an absent head
#: without end.
CONNECT_SECONDS = 10.0
#: How to get Ray.
INSTALL = 'pip install ".[sweep]" (make .venv/.sweep in a checkout)'


class RayUnavailableError(RuntimeError):
    """Ray is not installed (the extra ``sweep``), or its cluster cannot be reached."""


class AddressError(ValueError):
    """An address that is not a Ray address, or one a run cannot use."""


def check_address(text: str) -> str:
    """``text`` if it is a Ray address: ``auto``, ``local`` or ``HOST:PORT`` (port 1-65535);
    AddressError naming the forms otherwise."""
    head = HEAD.fullmatch(text)
    if text in (AUTO, LOCAL) or (head is not None and 1 <= int(head.group(2)) <= 65535):
        return text
    raise AddressError(f"{text!r} is not a Ray address; give {ADDRESS_FORMS}")


def check_reachable(address: str) -> None:
    """For a head's address (``HOST:PORT``), RayUnavailableError unless its port accepts a
    connection within CONNECT_SECONDS; ``auto`` and ``local`` are Ray's to find or start."""
    head = HEAD.fullmatch(address)
    if head is None:
        return
    host = address.removeprefix("ray://").rsplit(":", 1)[0].strip("[]")
    try:
        socket.create_connection((host, int(head.group(2))), timeout=CONNECT_SECONDS).close()
    except OSError as exc:
        raise RayUnavailableError(
            f"no Ray head answers at {address} ({exc.strerror or exc}); start one there "
            "(ray start --head --port=PORT) or give the address of a running head"
        ) from None


def need_ray(what: str) -> ModuleType:
    """The ``ray`` module; :class:`RayUnavailableError` saying that ``what`` needs it and how
    to install it if it is missing."""
    try:
        import ray
    except ImportError:
        raise RayUnavailableError(f"{what} needs ray, which is not installed: {INSTALL}") from None
    return ray


def start_ray(address: str | None, num_cpus: int) -> None:
    """Connect to the cluster at ``address``, or (None or ``local``) start a local instance on
    the loopback interface with ``num_cpus`` CPUs, no dashboard and no usage reporting.
    ``MUJOCO_GL`` is passed on to Ray's workers, which run one BLAS thread each. (Callers
    check first with :func:`need_ray` that Ray is installed, and with :func:`check_reachable`
    that a head answers at ``address``: ``ray.init`` would wait for it without end.)"""
    import ray

    os.environ["RAY_USAGE_STATS_ENABLED"] = "0"
    env_vars = {
        "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),
        "OMP_NUM_THREADS": "1",  # one task or actor per CPU: no BLAS threads on top
        "RAY_USAGE_STATS_ENABLED": "0",
    }
    if address not in (None, LOCAL):
        ray.init(address=address, runtime_env={"env_vars": env_vars}, log_to_driver=False)
    else:  # Ray's single-machine mode (as on macOS): the node's address is the loopback one
        os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"  # for the processes Ray starts
        ray._private.ray_constants.ENABLE_RAY_CLUSTER = False  # for this one (read at import)
        ray.init(
            address=LOCAL,  # a new instance, never one a `ray start` left behind
            num_cpus=num_cpus,
            include_dashboard=False,
            _node_ip_address=LOOPBACK,
            runtime_env={"env_vars": env_vars},
            log_to_driver=False,
        )
