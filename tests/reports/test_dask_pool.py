"""A local Dask pool (``--dask local:N``) keeps to this machine: with the dashboard off its
scheduler still starts an HTTP server (health, metrics), which took port 8787 on every
interface, or warned "Port 8787 is already in use" beside another cluster (seen in the
suite, two workers each with a local pool). It now listens on the loopback at a free port."""

from __future__ import annotations

import contextlib
import socket
import warnings

from volcaustics.reports.measuring.pools.executors import open_pool


def test_a_local_dask_pool_listens_on_the_loopback_and_does_not_warn_beside_another():
    with contextlib.ExitStack() as stack:
        taken = stack.enter_context(socket.socket())
        with contextlib.suppress(OSError):  # 8787 held here, or already held by someone else: taken either way
            taken.bind(("0.0.0.0", 8787))
            taken.listen()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with open_pool(dask="local:1") as pool:
                http = pool.client.cluster.scheduler.http_server
                host, port = http.address, http.port
    assert not [w for w in caught if "already in use" in str(w.message)], [str(w.message) for w in caught]
    assert host == "127.0.0.1" and port != 8787, (host, port)
