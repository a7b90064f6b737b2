"""Screenshots of the documentation site as a reader's browser shows it (headless Chromium).

Serves a built site (``site/`` by default; ``--build`` runs ``mkdocs build`` first) on a
local port and writes one PNG per page into ``--out``: by default the home page, the
`pdw-fit` command page, the tour, the model page and notebook 02's page. Needs a Chromium
or Chrome binary (``--browser``, else the first of chromium, chromium-browser,
google-chrome on the PATH; on Debian: ``apt-get install chromium``); the site and the
package do not.

    python scripts/make_screenshots.py --build --out screenshots

The machine may have no network: the pages' MathJax is loaded from a CDN, so without a
network the math shows as its TeX source (the page says which).
"""

from __future__ import annotations

import argparse
import functools
import http.server
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: (file name, page path on the site)
PAGES = (("home", ""), ("fit", "commands/fit/"), ("tour", "tour/"), ("model", "model/"),
         ("notebook", "notebooks/02_fit_your_gait/"))
BROWSERS = ("chromium", "chromium-browser", "google-chrome")
#: a headless start that does not reach for the network (a closed network refuses it)
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars", "--force-device-scale-factor=1")


def browser(name: str | None) -> str:
    """The browser binary to use (SystemExit with what to install when there is none)."""
    found = shutil.which(name) if name else next(
        (p for p in map(shutil.which, BROWSERS) if p), None)
    if not found:
        raise SystemExit(f"no browser found ({name or ', '.join(BROWSERS)}): install "
                         "Chromium (Debian: apt-get install chromium) or give --browser")
    return found


def serve(site: Path) -> tuple[http.server.ThreadingHTTPServer, str]:
    """A local HTTP server of ``site`` on a free port, on a daemon thread, and its URL."""
    handler = functools.partial(_Quiet, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, f"http://127.0.0.1:{server.server_address[1]}/"


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):  # one line per request would drown the progress
        pass


def shoot(binary: str, url: str, png: Path, width: int, height: int,
          wait_ms: int) -> None:
    """One page at ``url`` into ``png`` (``width`` x ``height`` px, after ``wait_ms`` of
    the page's own time for its scripts)."""
    with tempfile.TemporaryDirectory() as profile:
        cmd = [binary, *FLAGS, f"--user-data-dir={profile}", f"--window-size={width},{height}",
               f"--virtual-time-budget={wait_ms}", f"--screenshot={png}", url]
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    if done.returncode != 0 or not png.exists():
        raise SystemExit(f"the browser failed on {url} (exit {done.returncode}):\n"
                         f"{done.stderr[-2000:]}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--site", type=Path, default=ROOT / "site", help="the built site")
    ap.add_argument("--build", action="store_true", help="run mkdocs build first")
    ap.add_argument("--out", type=Path, default=Path("screenshots"), help="folder of PNGs")
    ap.add_argument("--browser", help="a Chromium or Chrome binary (default: found on PATH)")
    ap.add_argument("--width", type=int, default=1280, help="px")
    ap.add_argument("--height", type=int, default=1800, help="px")
    ap.add_argument("--wait-ms", type=int, default=4000,
                    help="page time for its scripts before the picture (ms)")
    ap.add_argument("--page", action="append", metavar="NAME=PATH",
                    help="a page to take instead of the default set (repeatable)")
    args = ap.parse_args(argv)
    binary = browser(args.browser)
    if args.build:
        subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                        str(args.site)], cwd=ROOT, check=True)
    if not (args.site / "index.html").exists():
        raise SystemExit(f"no built site at {args.site}: run with --build")
    pages = [tuple(p.split("=", 1)) for p in args.page] if args.page else PAGES
    args.out.mkdir(parents=True, exist_ok=True)
    server, url = serve(args.site)
    try:
        for name, path in pages:
            if not (args.site / path / "index.html").exists():
                raise SystemExit(f"the site has no page {path!r}")
            t0 = time.perf_counter()
            png = args.out / f"{name}.png"
            shoot(binary, url + path, png, args.width, args.height, args.wait_ms)
            print(f"{png}  {url + path}  {time.perf_counter() - t0:.1f} s", flush=True)
    finally:
        server.shutdown()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
