"""``sonolux serve FIELD``: the field's web bundle in a cache folder, and a local web server
for the viewer (shipped built in ``sonolux/web_dist``) and the bundle.

The server listens on 127.0.0.1 unless a host is given: a bundle is the user's work, and
nothing here is meant for other machines. It serves ``/`` from the viewer and ``/bundle/`` from
the bundle, with the MIME types browsers need for modules and glTF, single byte ranges (the
viewer fetches one cell's block at a time) and ``Cache-Control: no-cache`` (a rebuilt bundle
is seen at once).

The cache folder is ``$SONOLUX_CACHE`` or ``$XDG_CACHE_HOME/sonolux`` (default
``~/.cache/sonolux``), then ``web/<key>``, the key a hash of the field file's absolute path,
size, modification time, the export options and the sonolux version: a changed field file or
a new sonolux gets a new bundle; an unchanged one is served at once.
"""

from __future__ import annotations

import hashlib
import http.server
import ipaddress
import json
import os
import re
import shutil
import socket
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

from sonolux.errors import SonoluxError
from sonolux.web.bundle import export_web
from sonolux.web.options import WebExportOptions

VIEWER_DIR = Path(__file__).resolve().parent.parent / "web_dist"
BUNDLE_PREFIX = "/bundle/"
MIME_TYPES = {
    ".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8",
    ".mjs": "text/javascript; charset=utf-8", ".css": "text/css; charset=utf-8",
    ".json": "application/json", ".map": "application/json", ".glb": "model/gltf-binary",
    ".gltf": "model/gltf+json", ".bin": "application/octet-stream", ".wasm": "application/wasm",
    ".svg": "image/svg+xml", ".png": "image/png", ".ico": "image/x-icon", ".txt": "text/plain",
    ".wav": "audio/wav", "": "application/octet-stream",
}
_RANGE = re.compile(r"^bytes=(\d*)-(\d*)$")


def cache_root() -> Path:
    if os.environ.get("SONOLUX_CACHE"):
        return Path(os.environ["SONOLUX_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "sonolux"


def bundle_key(field_path: Path, options: WebExportOptions) -> str:
    from sonolux.version import __version__

    p = field_path.resolve()
    st = p.stat()
    text = json.dumps([str(p), st.st_size, st.st_mtime_ns, asdict(options), __version__])
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def cached_bundle(field_path: str | Path, options: WebExportOptions | None = None,
                  log: Callable[[str], None] | None = None, rebuild: bool = False) -> Path:
    """The bundle of ``field_path`` in the cache, exported first when it is not there (or
    when ``rebuild`` is asked)."""
    options = (options or WebExportOptions()).validate()
    field_path = Path(field_path)
    if not field_path.exists():
        raise SonoluxError(f"{field_path}: no such file")
    out = cache_root() / "web" / bundle_key(field_path, options)
    if rebuild and out.exists():
        shutil.rmtree(out)
    if (out / "field.json").exists():
        (log or (lambda _m: None))(f"bundle in the cache: {out}")
        return out
    summary = export_web(field_path, out, options, log=log)
    if log:
        log(summary.describe())
    return out


def viewer_dir() -> Path:
    if not (VIEWER_DIR / "index.html").exists():
        raise SonoluxError(f"the viewer is not built ({VIEWER_DIR} has no index.html): in a source "
                           "checkout, run `make web` (needs Node.js and npm)")
    return VIEWER_DIR


class ViewerHandler(http.server.SimpleHTTPRequestHandler):
    """Serves the viewer at / and the bundle at /bundle/, with single byte ranges."""

    extensions_map = MIME_TYPES
    viewer: Path = VIEWER_DIR
    bundle: Path = Path(".")
    quiet = True

    def translate_path(self, path: str) -> str:
        path = path.split("?", 1)[0].split("#", 1)[0]
        if path.startswith(BUNDLE_PREFIX):
            root, rest = self.bundle, path[len(BUNDLE_PREFIX) - 1:]
        else:
            root, rest = self.viewer, path
        # The base class maps the URL path into ``directory`` and refuses to step out of it.
        self.directory = str(root)
        return super().translate_path(rest)

    def end_headers(self) -> None:
        self.send_header("Cache-Control", "no-cache")
        self.send_header("X-Content-Type-Options", "nosniff")
        super().end_headers()

    def send_head(self):
        spec = self.headers.get("Range")
        path = self.translate_path(self.path)
        if not spec or not os.path.isfile(path):
            return super().send_head()
        size = os.path.getsize(path)
        m = _RANGE.match(spec.strip())
        if not m or (m.group(1) == "" and m.group(2) == ""):
            return super().send_head()  # several ranges or a unit we do not know: the whole file
        if m.group(1) == "":
            first, last = max(0, size - int(m.group(2))), size - 1
        else:
            first = int(m.group(1))
            last = min(size - 1, int(m.group(2))) if m.group(2) else size - 1
        if first >= size or last < first:
            self.send_response(416)
            self.send_header("Content-Range", f"bytes */{size}")
            self.send_header("Content-Length", "0")
            self.end_headers()
            return None
        f = open(path, "rb")
        f.seek(first)
        self.send_response(206)
        self.send_header("Content-Type", self.guess_type(path))
        self.send_header("Content-Range", f"bytes {first}-{last}/{size}")
        self.send_header("Content-Length", str(last - first + 1))
        self.send_header("Accept-Ranges", "bytes")
        self.end_headers()
        return _Slice(f, last - first + 1)

    def send_response(self, code, message=None):
        super().send_response(code, message)
        if code == 200:
            self.send_header("Accept-Ranges", "bytes")

    def list_directory(self, path):
        self.send_error(404, "no listing here")
        return None

    def log_message(self, format, *args):  # noqa: A002 (the base class's name)
        if not self.quiet:
            super().log_message(format, *args)


class _Slice:
    """The part of an open file that a 206 answer sends (copyfile reads until empty)."""

    def __init__(self, f, n: int):
        self.f, self.left = f, n

    def read(self, size: int = -1) -> bytes:
        n = self.left if size < 0 else min(size, self.left)
        data = self.f.read(n)
        self.left -= len(data)
        return data

    def close(self) -> None:
        self.f.close()


def make_server(bundle: Path, host: str = "127.0.0.1", port: int = 8765,
                quiet: bool = True) -> http.server.ThreadingHTTPServer:
    """A server (not started) for the viewer and ``bundle``; port 0 takes any free port."""
    handler = type("Handler", (ViewerHandler,), {"viewer": viewer_dir(), "bundle": Path(bundle),
                                                 "quiet": quiet})
    server_class = http.server.ThreadingHTTPServer
    if _is_ipv6(host):
        server_class = type("Server6", (server_class,), {"address_family": socket.AF_INET6})
    try:
        server = server_class((host, port), handler)
    except OSError as exc:
        raise SonoluxError(f"cannot listen on {host}:{port} ({exc.strerror or exc}); choose another "
                           "port with --port, or --port 0 for any free one") from None
    server.daemon_threads = True
    return server


def url_of(server: http.server.ThreadingHTTPServer) -> str:
    host, port = server.server_address[:2]
    shown = f"[{host}]" if _is_ipv6(host) else host
    return f"http://{shown}:{port}/"


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _is_ipv6(host: str) -> bool:
    try:
        return ipaddress.ip_address(host).version == 6
    except ValueError:
        return False

