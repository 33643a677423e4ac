"""Faults of the Dask layer of ``colony case``: a --scheduler that is none, absurd --workers.

Also the quiet LocalCluster (cases.sweep.check_scheduler, check_workers, _client).
"""

import http.server
import logging
import socket
import sys
import threading
import time
import warnings
from pathlib import Path

import pytest

from cases import sweep as S

TIMEOUT = 2.0  # the connect bound in these tests (the command's is CONNECT_TIMEOUT, 10 s)


def touch_run(params: dict, folder: Path) -> None:
    """Trivial picklable run."""
    (folder / "x.txt").write_text(str(params["lam"]))


def _serve(handle):
    """A listening socket on a free local port whose connections go to ``handle(conn)``."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(16)
    kept = []

    def loop():
        while True:
            try:
                conn, _ = server.accept()
            except OSError:  # closed
                return
            kept.append(conn)
            handle(conn)

    threading.Thread(target=loop, daemon=True).start()
    return server, f"tcp://127.0.0.1:{server.getsockname()[1]}"


@pytest.fixture
def silent():
    """Address of a socket that accepts connections and never answers."""
    server, address = _serve(lambda conn: None)
    yield address
    server.close()


@pytest.fixture
def upgrade_required():
    """Address of a host that answers every connection at once with HTTP 426."""
    server, address = _serve(lambda conn: conn.sendall(
        b"HTTP/1.1 426 Upgrade Required\r\nUpgrade: TLS/1.2\r\nContent-Length: 0\r\n\r\n"))
    yield address
    server.close()


class _Answer426(http.server.BaseHTTPRequestHandler):
    def do_GET(self):  # noqa: N802 (http.server's name)
        self.send_response(426)
        self.end_headers()

    def log_message(self, *args):
        pass


@pytest.fixture
def http_server():
    """Address of a real HTTP server (http.server) answering 426 to every request."""
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Answer426)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield f"tcp://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


def _refuse(address):
    with pytest.raises(S.SchedulerError) as info:
        start = time.monotonic()
        try:
            S.check_scheduler(address, TIMEOUT)
        finally:
            took = time.monotonic() - start
    message = str(info.value)
    assert took < TIMEOUT + 1.5, took
    assert "\n" not in message
    assert message.startswith(f"no Dask scheduler answers at {address} within 2 s: ")
    return message


@pytest.mark.parametrize("service", ["silent", "http_server"])
def test_a_service_that_does_not_answer_is_refused_within_the_timeout(service, request):
    message = _refuse(request.getfixturevalue(service))
    assert message.endswith("it accepts connections but does not answer "
                            "(an HTTP server or another service?)")


def test_an_http_answer_is_refused_not_read_as_an_exabyte_frame(upgrade_required):
    message = _refuse(upgrade_required)
    assert "it does not speak Dask's protocol" in message and "EiB" not in message


def test_nothing_listening_and_a_malformed_address_are_refused():
    probe = socket.socket()
    probe.bind(("127.0.0.1", 0))
    address = f"tcp://127.0.0.1:{probe.getsockname()[1]}"
    probe.close()  # a port nothing listens on
    assert _refuse(address).endswith("nothing accepts connections there "
                                     "(refused, or an unknown or unreachable host)")
    for bad, why in [("localhost", "missing port number"), ("http://h:80", "unknown address "
                                                                          "scheme 'http'")]:
        with pytest.raises(S.SchedulerError, match=f"--scheduler '{bad}' is not a Dask "
                           f"address like tcp://host:8786: {why}"):
            S.check_scheduler(bad, TIMEOUT)


def test_a_scheduler_passes_and_a_worker_is_refused(tmp_path):
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=1, processes=False, dashboard_address=None,
                      scheduler_kwargs={"dashboard_address": "127.0.0.1:0"}) as cluster:
        S.check_scheduler(cluster.scheduler_address, TIMEOUT)
        folders = S.sweep(touch_run, [{"lam": 2.0}], tmp_path, scheduler=cluster.scheduler_address,
                          progress=False)
        assert (folders[0] / "x.txt").read_text() == "2.0"
        worker = next(iter(cluster.scheduler.workers))
        assert _refuse(worker).endswith("it answers as 'Worker', not as a scheduler")


def test_sweep_and_colony_case_stop_in_one_line(silent, tmp_path, monkeypatch, colony):
    monkeypatch.setattr(S, "CONNECT_TIMEOUT", TIMEOUT)
    with pytest.raises(S.SchedulerError, match="no Dask scheduler answers"):
        S.sweep(touch_run, [{"lam": 1.0}], tmp_path / "runs", scheduler=silent, progress=False)
    start = time.monotonic()
    status, err = colony("case", "fig2", "--scale", "smoke", "--out", str(tmp_path / "case"),
                         "--scheduler", silent)
    assert time.monotonic() - start < TIMEOUT + 5
    assert status == 2
    assert err == (f"colony: error: no Dask scheduler answers at {silent} within 2 s: "
                   "it accepts connections but does not answer (an HTTP server or another "
                   "service?)\n")


@pytest.mark.parametrize("option", ["--scheduler", "--workers"])
def test_colony_case_creates_nothing_before_the_dask_checks(option, silent, tmp_path,
                                                            monkeypatch, colony):
    monkeypatch.setattr(S, "CONNECT_TIMEOUT", TIMEOUT)
    runs = tmp_path / "shared-runs"
    value = silent if option == "--scheduler" else "100000"
    status, err = colony("case", "fig2", "--scale", "smoke", "--out", str(tmp_path / "case"),
                         "--runs", str(runs), option, value)
    assert status == 2 and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_absurd_worker_counts_are_refused_before_any_process():
    most = S.WORKERS_PER_CORE * S._cores()
    S.check_workers(1)
    S.check_workers(most)
    for n in (0, most + 1, 100000):
        with pytest.raises(ValueError, match=rf"^--workers {n}: give 1 to {most} local Dask "
                           rf"workers \(4 per CPU core, {S._cores()} cores here\)$"):
            S.check_workers(n)


def test_sweep_refuses_100000_workers_at_once(tmp_path):
    start = time.monotonic()
    with pytest.raises(ValueError, match="--workers 100000: give 1 to"):
        S.sweep(touch_run, [{"lam": 1.0}], tmp_path / "runs", n_workers=100000, progress=False)
    assert time.monotonic() - start < 10


class _Stderr(logging.StreamHandler):
    """A StreamHandler to the ``sys.stderr`` of the moment (the one capfd captures)."""

    stream = property(lambda self: sys.stderr, lambda self, value: None)


@pytest.fixture
def root_logging():
    """The root logger as ``colony`` sets it (cli.configure_logging): ``set(level)``."""
    root = logging.getLogger()
    handler = _Stderr()
    handler.setFormatter(logging.Formatter("colony: %(message)s"))
    level = root.level
    root.addHandler(handler)

    def set_level(new):
        root.setLevel(new)
        handler.setLevel(new)

    yield set_level
    root.removeHandler(handler)
    root.setLevel(level)


def _port_8787_taken():
    """Hold port 8787 (Dask's default HTTP port) if it is free, so that taking it would warn."""
    holder = socket.socket()
    try:
        holder.bind(("127.0.0.1", 8787))
        holder.listen(1)
    except OSError:  # taken already
        holder.close()
        return None
    return holder


def test_local_cluster_is_quiet_at_info_and_talks_at_debug(root_logging, tmp_path, capfd):
    holder = _port_8787_taken()
    try:
        root_logging(logging.INFO)
        logging.getLogger("cases").info("the case starts")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            S.sweep(touch_run, [{"lam": 1.0}], tmp_path / "quiet", n_workers=1, progress=False)
        err = capfd.readouterr().err
        assert err == "colony: the case starts\n"  # no Dask INFO lines, no proxy hint
        assert [str(w.message) for w in caught] == []  # no "Port 8787 is already in use"

        root_logging(logging.DEBUG)  # colony --verbose
        S.sweep(touch_run, [{"lam": 1.0}], tmp_path / "verbose", n_workers=1, progress=False)
        err = capfd.readouterr().err
        assert "Scheduler at:" in err and "Start worker at:" in err
    finally:
        if holder is not None:
            holder.close()
    assert (tmp_path / "quiet" / "lam=1" / "x.txt").read_text() == "1.0"
