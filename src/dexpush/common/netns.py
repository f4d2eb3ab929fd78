"""Keeping traffic on the machine: a network namespace with only the loopback interface up.

DDS discovers peers by multicast on every interface it finds, and a local Ray instance listens on
every interface whatever its node address. The ROS 2 example system, its tests and a local Ray
instance run inside a namespace whose one interface is ``lo`` (with a multicast route on it, so discovery
works there), and with ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` as well: no packet can reach
another machine. :func:`in_loopback_namespace` says whether this process is in one;
:func:`loopback_command` wraps a command to run in a new one (``unshare -rn``: an unprivileged
user and network namespace), :func:`run_in_loopback_namespace` runs it there unless this process is in one;
:data:`LOCALHOST_ENV` is the environment ROS 2 needs there.
"""

from __future__ import annotations

import os
import shutil
import socket
from pathlib import Path

__all__ = ["LOCALHOST_ENV", "in_loopback_namespace", "loopback_command", "ros_environment",
           "run_in_loopback_namespace", "why_not_loopback"]

#: ROS 2's own limit on discovery (Jazzy and later), set beside the namespace
LOCALHOST_ENV = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}

_SETUP = "ip link set lo up && ip route add 224.0.0.0/4 dev lo && exec \"$@\""


def why_not_loopback() -> str | None:
    """None when every network interface of this process is the loopback and it is up; else why not."""
    names = sorted(name for _, name in socket.if_nameindex())
    others = [n for n in names if n != "lo"]
    if others:
        return f"this process sees network interfaces besides lo ({', '.join(others)})"
    try:
        flags = int(Path("/sys/class/net/lo/flags").read_text(), 16)
    except (OSError, ValueError):
        flags = 0x1 if "lo" in names else 0
    if not flags & 0x1:
        return "the loopback interface is down"
    return None


def in_loopback_namespace() -> bool:
    """Whether this process's only network interface is an up loopback."""
    return why_not_loopback() is None


def loopback_command(argv: list[str]) -> list[str]:
    """``argv`` run in a new user and network namespace with only ``lo`` up (and a multicast route on it);
    an ``OSError`` when ``unshare`` or ``ip`` is missing."""
    for tool in ("unshare", "ip"):
        if shutil.which(tool) is None:
            raise OSError(f"{tool} is not installed: it makes the loopback-only network namespace ROS 2 runs in here")
    return ["unshare", "-rn", "sh", "-c", _SETUP, "sh", *argv]


def run_in_loopback_namespace(argv: list[str], env: dict[str, str] | None = None) -> int | None:
    """None when this process is in a loopback-only namespace already; else ``argv`` run in a new one (with
    ``env`` added to this environment) and its exit code. An ``OSError`` when a namespace made for this
    process (``DEXPUSH_IN_NAMESPACE`` set) is still not loopback-only, or ``unshare`` or ``ip`` is missing."""
    import subprocess

    why = why_not_loopback()
    if why is None:
        return None
    if os.environ.get("DEXPUSH_IN_NAMESPACE"):
        raise OSError(f"the new network namespace is not loopback-only ({why})")
    return subprocess.call(loopback_command(argv), env={**os.environ, **(env or {}), "DEXPUSH_IN_NAMESPACE": "1"})


def ros_environment() -> dict[str, str]:
    """This process's environment with :data:`LOCALHOST_ENV` set."""
    return {**os.environ, **LOCALHOST_ENV}
