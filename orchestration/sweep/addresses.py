"""A ``--scheduler`` address checked for its form before anything is built, created or printed (a
scheduler that cannot be reached is found when the sweep connects, still before its first line)."""
from __future__ import annotations

from orchestration.run.scenario import ScenarioError


def check_scheduler_address(address: str) -> str:
    """``address`` if it has the form of a dask.distributed scheduler address (scheme://host:port or
    host:port), else ``ScenarioError`` naming the option."""
    from distributed.comm.addressing import get_address_host_port

    if not address.strip():
        raise ScenarioError("--scheduler '': give a Dask scheduler address such as tcp://host:8786, or leave it out")
    try:
        _, port = get_address_host_port(address)
    except (ValueError, TypeError) as exc:  # no port, an unknown protocol, one without host and port
        raise ScenarioError(f"--scheduler {address}: not a Dask scheduler address such as tcp://host:8786 "
                            f"({exc})") from None
    if not 0 < port < 65536:
        raise ScenarioError(f"--scheduler {address}: port {port} is outside 1 to 65535")
    return address
