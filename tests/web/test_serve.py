"""``sonolux serve``: the cached bundle and the local server (loopback, MIME types, ranges)."""

from __future__ import annotations

import subprocess
import sys
import threading
import urllib.error
import urllib.request

import pytest

from sonolux.errors import SonoluxError
from sonolux.web import WebExportOptions
from sonolux.web.serve import cached_bundle, is_loopback, make_server, url_of

SHORT = WebExportOptions(max_length_s=0.1)


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SONOLUX_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


@pytest.fixture()
def server(sound_field, cache):
    bundle = cached_bundle(sound_field, SHORT)
    s = make_server(bundle, port=0)
    t = threading.Thread(target=s.serve_forever, daemon=True)
    t.start()
    yield url_of(s), bundle
    s.shutdown()
    s.server_close()


def get(url, headers=None):
    req = urllib.request.Request(url, headers=headers or {})
    with urllib.request.urlopen(req, timeout=10) as r:
        return r.status, r.headers, r.read()


def test_the_cache_is_reused_until_the_field_changes(sound_field, cache, tmp_path):
    import shutil

    a = cached_bundle(sound_field, SHORT)
    stamp = (a / "field.json").stat().st_mtime_ns
    assert cached_bundle(sound_field, SHORT) == a and (a / "field.json").stat().st_mtime_ns == stamp
    assert cached_bundle(sound_field, WebExportOptions(max_length_s=0.2)) != a
    assert a.parent == cache / "web"
    copy = tmp_path / "copy.h5"
    shutil.copy(sound_field, copy)
    assert cached_bundle(copy, SHORT) != a
    assert cached_bundle(sound_field, SHORT, rebuild=True) == a
    assert (a / "field.json").stat().st_mtime_ns != stamp
    with pytest.raises(SonoluxError, match="no such file"):
        cached_bundle(tmp_path / "none.h5")


def test_viewer_and_bundle_with_their_types(server):
    url, bundle = server
    status, h, body = get(url)
    assert status == 200 and h["Content-Type"].startswith("text/html") and b"<div id=\"view\">" in body
    assert h["Cache-Control"] == "no-cache"
    script = body.split(b'src="./')[1].split(b'"')[0].decode()
    assert get(url + script)[1]["Content-Type"].startswith("text/javascript")
    assert get(url + "bundle/field.json")[1]["Content-Type"] == "application/json"
    assert get(url + "bundle/scene.glb")[1]["Content-Type"] == "model/gltf-binary"
    for missing in ("bundle/nothing", "bundle/", "../../etc/passwd", "bundle/../../../../etc/passwd"):
        with pytest.raises(urllib.error.HTTPError) as e:
            get(url + missing)
        assert e.value.code == 404


def test_byte_ranges(server):
    url, bundle = server
    data = (bundle / "responses.bin").read_bytes()
    status, h, body = get(url + "bundle/responses.bin", {"Range": "bytes=100-199"})
    assert status == 206 and body == data[100:200]
    assert h["Content-Range"] == f"bytes 100-199/{len(data)}" and h["Content-Length"] == "100"
    assert get(url + "bundle/responses.bin", {"Range": "bytes=-10"})[2] == data[-10:]
    assert get(url + "bundle/responses.bin", {"Range": f"bytes={len(data) - 5}-"})[2] == data[-5:]
    status, h, body = get(url + "bundle/responses.bin")
    assert status == 200 and body == data and h["Accept-Ranges"] == "bytes"
    with pytest.raises(urllib.error.HTTPError) as e:
        get(url + "bundle/responses.bin", {"Range": f"bytes={len(data)}-"})
    assert e.value.code == 416


def test_loopback_only_unless_asked(sound_field, cache):
    s = make_server(cached_bundle(sound_field, SHORT), port=0)
    try:
        assert s.server_address[0] == "127.0.0.1"
    finally:
        s.server_close()
    assert is_loopback("127.0.0.1") and is_loopback("::1") and is_loopback("localhost")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.168.1.4")
    busy = make_server(cached_bundle(sound_field, SHORT), port=0)
    try:
        with pytest.raises(SonoluxError, match="--port"):
            make_server(cached_bundle(sound_field, SHORT), port=busy.server_address[1])
    finally:
        busy.server_close()


def test_the_command_prints_the_address_and_serves(sound_field, cache):
    proc = subprocess.Popen([sys.executable, "-c", "import sys; from sonolux.cli import main; "
                             "sys.exit(main(sys.argv[1:]))", "serve", str(sound_field), "--port", "0",
                             "--max-length-s", "0.1"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        assert "serving the walk-through" in line and "http://127.0.0.1:" in line
        url = line.split(" at ")[1].split()[0]
        assert get(url + "bundle/field.json")[0] == 200
    finally:
        proc.terminate()
        proc.wait(timeout=60)  # a loaded CI machine can take seconds to unwind
