"""The local server against odd and slow clients: odd paths are a clean 400/404, never a
traceback; 20 clients that connect and send nothing do not stop a normal client from loading
the page; a client that leaves mid-answer is not reported; idle connections are closed."""

from __future__ import annotations

import contextlib
import io
import os
import socket
import threading
import time
import urllib.error
import urllib.request

import pytest

from sonolux.web import WebExportOptions
from sonolux.web.serve import cached_bundle, make_server, url_of


@pytest.fixture(scope="module")
def server(field_file, tmp_path_factory):
    before = os.environ.get("SONOLUX_CACHE")
    os.environ["SONOLUX_CACHE"] = str(tmp_path_factory.mktemp("cache"))
    try:
        bundle = cached_bundle(field_file, WebExportOptions(max_length_s=0.1))
    finally:
        if before is None:
            os.environ.pop("SONOLUX_CACHE")
        else:
            os.environ["SONOLUX_CACHE"] = before
    s = make_server(bundle, port=0)
    s.RequestHandlerClass.timeout = 2  # idle connections closed quickly in the test
    errors = io.StringIO()
    with contextlib.redirect_stderr(errors):
        t = threading.Thread(target=s.serve_forever, daemon=True)
        t.start()
        yield s, url_of(s), errors
        s.shutdown()
        s.server_close()


def status(url: str) -> int:
    try:
        with urllib.request.urlopen(url, timeout=10) as r:
            r.read()
            return r.status
    except urllib.error.HTTPError as e:
        return e.code


ODD = ["/bundle/%00", "/%00", "/bundle/%2e%2e/%2e%2e/etc/passwd", "/../../etc/passwd",
       "/bundle/field.json%00.png", "/bundle/", "/bundle", "/nothing-here", "/%ff%fe",
       "/bundle/" + "a" * 3000, "/?%00", "/bundle/responses.bin/..", "//", "/.", "/%",
       "/bundle/%zz"]


@pytest.mark.parametrize("path", ODD)
def test_an_odd_path_is_a_clean_answer(server, path):
    _, url, errors = server
    code = status(url.rstrip("/") + path)
    assert code in (200, 301, 400, 404, 414), code
    time.sleep(0.05)
    assert "Traceback" not in errors.getvalue()


def test_idle_clients_do_not_stop_a_normal_one(server):
    s, url, errors = server
    host, port = s.server_address[:2]
    idle = [socket.create_connection((host, port)) for _ in range(20)]
    try:
        started = time.perf_counter()
        assert status(url) == 200
        assert status(url.rstrip("/") + "/bundle/field.json") == 200
        assert time.perf_counter() - started < 5
    finally:
        for c in idle:
            c.close()
    assert "Traceback" not in errors.getvalue()


def test_an_idle_connection_is_closed(server):
    s, _, _ = server
    host, port = s.server_address[:2]
    c = socket.create_connection((host, port))
    c.settimeout(10)
    started = time.perf_counter()
    assert c.recv(100) == b""  # closed by the server after its timeout
    assert time.perf_counter() - started < 8
    c.close()


def test_a_client_that_leaves_is_not_reported(server):
    s, _, errors = server
    host, port = s.server_address[:2]
    for _ in range(5):
        c = socket.create_connection((host, port))
        c.sendall(b"GET /bundle/responses.bin HTTP/1.1\r\nHost: x\r\n\r\n")
        c.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, b"\x01\x00\x00\x00\x00\x00\x00\x00")
        c.close()  # a reset, mid-answer
    time.sleep(0.5)
    assert "Traceback" not in errors.getvalue()


def test_the_bundle_cache_keeps_the_most_recent(tmp_path):
    from sonolux.web.serve import clean_cache

    folder = tmp_path / "web"
    folder.mkdir()
    for k in range(12):
        (folder / f"b{k:02d}").mkdir()
        os.utime(folder / f"b{k:02d}", (1000 + k, 1000 + k))
    (folder / "b01.partial-123").mkdir()  # another export, maybe running: left alone
    keep = folder / "b00"  # the one in use, however old
    clean_cache(folder, keep=keep, most=4)
    assert sorted(p.name for p in folder.iterdir()) == ["b00", "b01.partial-123", "b09", "b10",
                                                        "b11"]
