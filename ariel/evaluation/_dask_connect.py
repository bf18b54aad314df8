"""Reaching a Dask scheduler by its address: the address's form checked without Dask, and a
connection that gives up in bounded time, each failure one line (`DaskAddressError`).

`distributed.Client(address)` raises a ``ValueError`` deep in Dask for a malformed address,
retries a refused connection for 30 s and then raises ``OSError``, and waits for ever when
something other than Dask listens there (its handshake reads with no time limit). A run
would end in a traceback, or hang without a word. `address_problem` is cheap (no Dask
import), so an ``[executor]`` section can be checked before anything is written;
`connect_scheduler` first asks the scheduler who it is, in a thread it stops waiting for.
"""

from __future__ import annotations

import asyncio
import re
import threading
from types import ModuleType
from typing import TYPE_CHECKING

from ariel.errors import ConfigError

if TYPE_CHECKING:
    from distributed import Client

__all__ = [
    "CONNECT_SECONDS",
    "DASK_MISSING",
    "SCHEMES",
    "DaskAddressError",
    "address_problem",
    "check_scheduler",
    "connect_scheduler",
    "distributed_module",
]

#: The address schemes of Dask's network transports (``inproc`` reaches only this process).
SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")

#: ``[scheme://]host:port``, the host a name, an IPv4 address or a bracketed IPv6 one.
_ADDRESS = re.compile(
    r"(?:(?P<scheme>[A-Za-z][A-Za-z0-9+.-]*)://)?(?P<host>\[[0-9A-Fa-f:.]+\]|[^\s:/\[\]]+):(?P<port>[0-9]{1,5})"
)

#: Seconds a scheduler has to answer when a run connects to it (Dask's default connect
#: timeout, given explicitly: Dask's own wait has no limit when the peer is not Dask).
CONNECT_SECONDS = 30.0

DASK_MISSING = "Dask executor needs the optional extra: pip install 'ariel[distributed]'"


class DaskAddressError(ConfigError):
    """A Dask scheduler address that is malformed, or where no Dask scheduler answers."""


def address_problem(address: object) -> str | None:
    """What is wrong with the form of a Dask scheduler ``address`` (one line), or None.

    Args:
        address: ``[scheme://]host:port``, e.g. ``"tcp://10.0.0.5:8786"``.

    Returns:
        None for a well-formed address, else e.g. ``"'garbage' is not a Dask scheduler
        address: give [tcp|tls|ws|wss|ucx://]HOST:PORT, e.g. tcp://10.0.0.5:8786"``.
    """
    allowed = f"give [{'|'.join(SCHEMES)}://]HOST:PORT, e.g. tcp://10.0.0.5:8786"
    if not isinstance(address, str):
        return f"{address!r} is not a Dask scheduler address: {allowed}"
    if address.startswith("inproc://"):  # a scheduler in this process (`processes=False`)
        return None
    if address != address.strip():  # Dask would use it as it is: a host " tcp" or "8786 "
        return f"{address!r} has spaces around it; {allowed}"
    found = _ADDRESS.fullmatch(address)
    if found is None:
        return f"{address!r} is not a Dask scheduler address: {allowed}"
    scheme = (found["scheme"] or "tcp").lower()
    if scheme not in SCHEMES:
        return f"{address!r}: {scheme}:// is not a Dask transport; {allowed}"
    if not 0 < int(found["port"]) < 65536:
        return f"{address!r}: the port must be 1 to 65535; {allowed}"
    return None


def distributed_module() -> ModuleType:
    """``distributed``, imported now; `ImportError` naming the extra to install if missing,
    or saying in one line why Dask would not load (a malformed Dask configuration file,
    ``DASK_CONFIG`` or ``~/.config/dask/*.yaml``: Dask reads them on import)."""
    try:
        import distributed  # lazy: a heavy optional library, only for the dask executor
    except ImportError as exc:
        raise ImportError(DASK_MISSING) from exc
    except Exception as exc:  # its message spans lines: the YAML error is on the last ones
        reason = " ".join(str(exc).split())[:500]
        raise ImportError(f"Dask could not load: {reason or type(exc).__name__}") from exc
    return distributed


def connect_scheduler(address: str) -> Client:
    """A `distributed.Client` of the scheduler at ``address``, or one line why not.

    Within `CONNECT_SECONDS` the scheduler must say who it is (Dask's own connect gives up
    on a refused connection then, but waits for ever on a peer that never answers its
    handshake); only then is the client made, with the same timeout.

    Raises:
        DaskAddressError: The address is malformed, nothing listens there, or what listens
            does not answer as a Dask scheduler in time.
    """
    check_scheduler(address)
    try:
        return distributed_module().Client(address, timeout=CONNECT_SECONDS)
    except (OSError, ValueError) as exc:  # gone between the question and the client
        raise DaskAddressError(_unreachable(address, exc)) from None


def check_scheduler(address: str) -> None:
    """A Dask scheduler answers at ``address`` within `CONNECT_SECONDS` (`DaskAddressError`:
    one line why not); asked before a run or campaign folder is made, and by
    `connect_scheduler`."""
    problem = address_problem(address)
    if problem is not None:
        raise DaskAddressError(f"address: {problem}")
    _ask_identity(distributed_module(), address)


class _NotDaskError(Exception):
    """What answered could not be read as a Dask message (a server of another protocol)."""


def _ask_identity(distributed: ModuleType, address: str) -> None:
    """Ask the scheduler at ``address`` for its identity, in a thread of its own (a caller
    may run an event loop already, e.g. Jupyter), waiting at most `CONNECT_SECONDS`."""
    outcome: dict[str, object] = {}

    def ask() -> None:
        try:
            question = _identity(distributed, address)
            outcome["identity"] = asyncio.run(asyncio.wait_for(question, CONNECT_SECONDS))
        except BaseException as exc:  # handed to the caller's thread
            outcome["error"] = exc

    thread = threading.Thread(target=ask, name="ariel-dask-connect", daemon=True)
    thread.start()
    thread.join(CONNECT_SECONDS + 5.0)  # the thread's own limit, and then some
    error = outcome.get("error")
    if thread.is_alive() or isinstance(error, asyncio.TimeoutError):
        raise DaskAddressError(
            f"address: no Dask scheduler answered at {address} within {CONNECT_SECONDS:g} s "
            "(is it running, and is it a Dask scheduler that listens there?)"
        )
    if isinstance(error, _NotDaskError):
        raise DaskAddressError(
            f"address: {address} is not a Dask scheduler (what answered there does not speak "
            f"Dask's protocol: {type(error.__cause__).__name__})"
        )
    if isinstance(error, BaseException):
        raise DaskAddressError(_unreachable(address, error)) from None
    identity = outcome.get("identity")
    if not isinstance(identity, dict) or identity.get("type") != "Scheduler":
        raise DaskAddressError(
            f"address: {address} is not a Dask scheduler (it answered {str(identity)[:80]!r})"
        )


async def _identity(distributed: ModuleType, address: str) -> object:
    # Security from Dask's configuration, as a Client would take it (tls:// needs it).
    arguments = distributed.Security().get_connection_args("client")
    try:
        comm = await distributed.connect(address, timeout=CONNECT_SECONDS, **arguments)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()
    except distributed.comm.CommClosedError as exc:  # it took the connection, then hung up
        raise _NotDaskError() from exc
    except (OSError, TimeoutError):  # refused, unreachable; or no answer in time
        raise
    except Exception as exc:  # any: e.g. an SSH banner read as a frame length (MemoryError)
        if not address.startswith("tcp://"):  # tls:// without certificates, ucx:// without
            raise  # UCX: said as it is (it was "not a Dask scheduler", nothing having answered)
        raise _NotDaskError() from exc


def _unreachable(address: str, exc: BaseException) -> str:
    if address.startswith("inproc://"):  # Dask's own error: "not enough values to unpack"
        return (
            f"address: no Dask scheduler of this process is at {address} (inproc:// reaches "
            "one made in this Python process, e.g. LocalCluster(processes=False); from another "
            "process or the command line give tcp://HOST:PORT)"
        )
    reason = (str(exc).strip().splitlines() or [""])[0][:200]
    return f"address: cannot reach the Dask scheduler at {address}: {type(exc).__name__}: {reason}"
