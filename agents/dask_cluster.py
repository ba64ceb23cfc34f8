"""Reaching a Dask scheduler: where the runner's jobs run (docs/scaling.md): ``None`` here,
serially; ``"local:N"`` a ``LocalCluster`` of N one-thread workers started here;
``"tcp://HOST:PORT"`` (or ``"HOST:PORT"``) a running scheduler. Dask is imported only when a
client is made (:func:`dask_client`).
"""

from __future__ import annotations

import contextlib
import logging
import re
import signal
import socket
import sys
import threading
import time
from collections.abc import Iterator
from typing import TYPE_CHECKING

from tandem_env.envs.declaration import refusal
from tandem_env.physics.checks import is_integer

if TYPE_CHECKING:
    from distributed import Client

#: Seconds to wait for a Dask scheduler to answer before giving up [s].
CONNECT_TIMEOUT = 10.0
#: Most worker processes ``local:N`` starts on this machine [-].
MAX_LOCAL_WORKERS = 1024
#: TCP ports a scheduler address may name [-].
PORTS = (1, 65535)
#: The one transport the runner connects to (Dask's tls:// needs certificates it does not take).
SCHEME = "tcp"
_ALLOWED = (
    f"local:N (N = 1 to {MAX_LOCAL_WORKERS} worker processes started here) or the address of a "
    f"running Dask scheduler, {SCHEME}://HOST:PORT or HOST:PORT with PORT {PORTS[0]} to "
    f"{PORTS[1]}, e.g. {SCHEME}://HOST:8786"
)
#: A host name or IPv4 address of a scheduler address (RFC 1123 lengths; '_' as resolvers allow).
_HOST = re.compile(
    r"(?=.{1,253}$)[A-Za-z0-9_](?:[A-Za-z0-9_-]{0,61}[A-Za-z0-9_])?"
    r"(?:\.[A-Za-z0-9_](?:[A-Za-z0-9_-]{0,61}[A-Za-z0-9_])?)*\.?"
)
# The largest first frame a Dask scheduler's handshake can plausibly have [bytes] (_probe).
_HANDSHAKE_BYTES = 1 << 24


class SchedulerUnreachable(ConnectionError):
    """No Dask scheduler answers at the address given."""


def parse_scheduler(text: str) -> str:
    """Validate a ``--scheduler`` value; returns it normalised (``HOST:PORT`` -> ``tcp://...``);
    ValueError naming the value and what is allowed."""
    if not isinstance(text, str):
        raise ValueError(f"scheduler = {text!r}; allowed: a string, {_ALLOWED}")
    text = text.strip()

    def refused(why: str = "") -> ValueError:
        return ValueError(f"--scheduler {text!r}{why}; allowed: {_ALLOWED}")

    if text.startswith("local:"):
        n = text.partition(":")[2]
        if not n.isdigit() or not 1 <= int(n) <= MAX_LOCAL_WORKERS:
            workers = f"a whole number N of worker processes from 1 to {MAX_LOCAL_WORKERS}"
            raise refused(f": local:N needs {workers}")
        return f"local:{int(n)}"
    scheme, _, rest = text.rpartition("://")
    if scheme and scheme != SCHEME:
        raise refused(f": the scheme {scheme + '://'!r} is not supported")
    if (match := re.fullmatch(r"(\[[0-9a-fA-F:]+\]|[^\s/:\[\]]+):(\d{1,6})", rest)) is None:
        raise refused()
    host, port = match.groups()
    if not host.startswith("[") and not _HOST.fullmatch(host):
        # The resolver refuses other names with a codec error ("label too long") or a NUL.
        short = host if len(host) <= 40 else f"{host[:40]}…"
        raise refused(
            f": {short!r} is not a host name (letters, digits, '-', '.', '_'; labels of 1 to 63, "
            "at most 253 in all) nor an IP address"
        )
    if not PORTS[0] <= int(port) <= PORTS[1]:
        raise refused(f": port {int(port)} is outside {PORTS[0]} to {PORTS[1]}")
    return f"{SCHEME}://{host}:{int(port)}"


def executor_spec(scheduler: str | None, workers: int = 1) -> str | None:
    """The executor from ``scheduler`` and the shorthand ``workers=N`` (N > 1 means ``local:N``;
    1, the default, leaves ``scheduler`` as given)."""
    if not is_integer(workers) or not 1 <= workers <= MAX_LOCAL_WORKERS:
        allowed = f"an integer from 1 to {MAX_LOCAL_WORKERS} (N > 1 means local:N)"
        raise refusal("workers", workers, allowed)
    if workers == 1:
        return None if scheduler is None else parse_scheduler(scheduler)
    if scheduler is not None:
        raise ValueError(
            f"workers = {workers} and scheduler = {scheduler!r}; give one (workers N is local:N)"
        )
    return f"local:{int(workers)}"


def _probe(address: str) -> None:
    """Check that a Dask scheduler answers at ``address`` within :data:`CONNECT_TIMEOUT`: fail
    fast where the client would retry, and read the handshake a scheduler sends first (an
    8-byte little-endian frame length), so a silent port or another protocol is reported
    instead of hanging the client or making it allocate an absurd length."""
    host, port = address.removeprefix(f"{SCHEME}://").rsplit(":", 1)
    deadline = time.monotonic() + CONNECT_TIMEOUT
    advice = (
        "start one with `dask scheduler` and workers with `dask worker ADDRESS` "
        "(docs/scaling.md), or run here with --scheduler local:N"
    )
    try:
        conn = socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_TIMEOUT)
    except OSError as error:  # refused, unknown host, or no answer to connect (TimeoutError)
        raise SchedulerUnreachable(
            f"no Dask scheduler answers at {address} ({error.strerror or error}); {advice}"
        ) from None

    def unreachable(what: str) -> SchedulerUnreachable:
        return SchedulerUnreachable(f"{address} {what}: not a Dask scheduler; {advice}")

    head = b""
    with conn:
        try:
            while len(head) < 8:
                conn.settimeout(max(deadline - time.monotonic(), 1e-3))
                chunk = conn.recv(8 - len(head))
                if not chunk:
                    break
                head += chunk
        except TimeoutError:
            wait = f"within {CONNECT_TIMEOUT:g} s (or a stalled scheduler)"
            raise unreachable(f"accepts connections but sent no Dask handshake {wait}") from None
        except OSError as error:
            why = error.strerror or error
            raise unreachable(f"dropped the connection ({why}) before a Dask handshake") from None
    if len(head) < 8:
        raise unreachable("accepted the connection and closed it without a Dask handshake")
    if not 0 < int.from_bytes(head, "little") <= _HANDSHAKE_BYTES:
        raise unreachable(f"answers, but not with the Dask protocol (first bytes {head!r})")


@contextlib.contextmanager
def dask_client(scheduler: str, *, quiet: bool = False) -> Iterator[Client]:
    """A client of ``scheduler`` (``local:N`` or an address), closed (with its cluster) at exit;
    :class:`SchedulerUnreachable` if none answers within :data:`CONNECT_TIMEOUT` seconds."""
    from distributed import Client, LocalCluster

    spec = parse_scheduler(scheduler)
    with contextlib.ExitStack() as stack:
        if spec.startswith("local:"):
            # worker processes that ignore Ctrl-C (SIGINT, sent to the whole process group), so
            # only this process handles it and closes the cluster in order (the ignore is inherited)
            main = threading.current_thread() is threading.main_thread()
            previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
            try:
                cluster = LocalCluster(
                    n_workers=int(spec.partition(":")[2]),
                    threads_per_worker=1,
                    processes=True,
                    host="127.0.0.1",
                    dashboard_address="127.0.0.1:0",  # a free port (the dashboard needs bokeh)
                    env={"NUMBA_NUM_THREADS": "1"},  # a job per core: agents.runner._on_worker
                    # the runner reports every failed job itself (key and traceback) and Dask
                    # reruns a dead worker's jobs: the cluster's own ERROR logs are noise
                    silence_logs=logging.CRITICAL,
                )
            finally:
                if main:
                    signal.signal(signal.SIGINT, previous)
            stack.enter_context(cluster)
            client = stack.enter_context(Client(cluster))
        else:
            _probe(spec)
            try:
                client = stack.enter_context(Client(spec, timeout=CONNECT_TIMEOUT))
            except OSError as error:
                raise SchedulerUnreachable(
                    f"cannot connect to the Dask scheduler at {spec}: {error}"
                ) from None
        if not quiet:
            workers = len(client.scheduler_info().get("workers", {}))
            where = f"Dask scheduler {client.scheduler.address}, {workers} workers"
            if workers == 0:
                where += " (jobs wait until workers connect)"
            with contextlib.suppress(Exception):  # no dashboard service (bokeh missing)
                if client.scheduler_info().get("services") and client.dashboard_link:
                    where += f", dashboard {client.dashboard_link}"
            print(where, file=sys.stderr)
        yield client
