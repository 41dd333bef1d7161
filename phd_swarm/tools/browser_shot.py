"""Screenshots of a web page in headless Chromium, over the DevTools protocol on a pipe.

``python -m phd_swarm.tools.browser_shot URL OUT.png [--wait-colour R,G,B ...]`` opens the
URL in headless Chromium (Debian's ``chromium``) and saves a screenshot. The live view
(docs/view.md) uses it for its tests and for the pictures in docs/.

Why not ``chromium --screenshot``: it fires when the page has loaded, before a WebAssembly
application such as the Rerun viewer has drawn anything, so it catches a blank page. Here
the browser is driven through the DevTools protocol (CDP) on ``--remote-debugging-pipe``
(file descriptors 3 and 4, JSON messages ended by a NUL byte): no debugging port is opened
at all. :meth:`Browser.shot_until` takes screenshots until one holds every colour asked
for (the page has drawn what it should) or the time is up, so a slow machine waits longer
rather than failing by chance.

Nothing leaves the machine: the browser resolves no host name but 127.0.0.1 and localhost
(``--host-resolver-rules``), WebGL runs on SwiftShader (no GPU here), and the profile is a
temporary directory removed at the end.
"""

from __future__ import annotations

import argparse
import base64
import fcntl
import io
import json
import os
import select
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence

import numpy as np

#: Chromium's flags: headless, software WebGL / WebGPU, nothing but loopback, no first-run UI.
CHROMIUM_FLAGS = (
    "--headless=new",
    "--no-sandbox",                    # root in CI; the page is our own, on loopback
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--ignore-gpu-blocklist",
    "--no-first-run",
    "--no-default-browser-check",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--metrics-recording-only",
    "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE localhost, EXCLUDE 127.0.0.1",
)


class BrowserError(RuntimeError):
    """The browser could not be started, or a DevTools command failed."""


def chromium_path() -> str:
    """The Chromium executable (``$CHROMIUM`` or ``chromium`` on PATH)."""
    path = os.environ.get("CHROMIUM") or shutil.which("chromium") or shutil.which(
        "chromium-browser")
    if not path:
        raise BrowserError("no chromium on PATH (Debian: apt-get install chromium; or set "
                           "CHROMIUM to its path)")
    return path


class Browser:
    """A headless Chromium driven over the DevTools pipe; a context manager.

    Parameters
    ----------
    width, height : int
        The window in CSS pixels (the screenshot's size).
    """

    def __init__(self, width: int = 1600, height: int = 1000) -> None:
        self._profile = tempfile.mkdtemp(prefix="phd_swarm_chromium_")
        to_browser_r, self._to_browser = os.pipe()
        self._from_browser, from_browser_w = os.pipe()
        # The child reads commands on fd 3 and writes answers on fd 4. The pipe's ends are
        # first moved above 9, so that placing one on 3 cannot overwrite the other.
        def child_fds() -> None:
            high = [fcntl.fcntl(fd, fcntl.F_DUPFD, 10) for fd in (to_browser_r,
                                                                  from_browser_w)]
            os.dup2(high[0], 3)
            os.dup2(high[1], 4)
        cmd = [chromium_path(), *CHROMIUM_FLAGS, "--remote-debugging-pipe",
               f"--user-data-dir={self._profile}", f"--window-size={width},{height}",
               "about:blank"]
        self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                     pass_fds=(3, 4),
                                     preexec_fn=child_fds, start_new_session=True)
        os.close(to_browser_r)
        os.close(from_browser_w)
        self._next_id = 0
        self._buffer = b""
        self._session = ""
        self.width, self.height = width, height

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Stop the browser (its whole process group, by PID) and remove its profile."""
        for fd in (self._to_browser, self._from_browser):
            try:
                os.close(fd)
            except OSError:
                pass
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, 15)
                self.proc.wait(timeout=10)
            except (ProcessLookupError, subprocess.TimeoutExpired):
                os.killpg(self.proc.pid, 9)
                self.proc.wait()
        shutil.rmtree(self._profile, ignore_errors=True)

    def _read_message(self, deadline: float) -> dict:
        while b"\0" not in self._buffer:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self._from_browser], [], [], left)[0]:
                raise BrowserError("no answer from the browser within the time")
            chunk = os.read(self._from_browser, 1 << 20)
            if not chunk:
                err = self.proc.stderr.read().decode(errors="replace") if self.proc.stderr \
                    else ""
                raise BrowserError(f"the browser closed its DevTools pipe: {err[-2000:]}")
            self._buffer += chunk
        message, self._buffer = self._buffer.split(b"\0", 1)
        return json.loads(message)

    def command(self, method: str, timeout: float = 60.0, session: bool = True,
                **params: object) -> dict:
        """Send one DevTools command (to the page, once opened) and return its result."""
        self._next_id += 1
        message = {"id": self._next_id, "method": method, "params": params}
        if session and self._session:
            message["sessionId"] = self._session
        os.write(self._to_browser, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + timeout
        while True:
            answer = self._read_message(deadline)
            if answer.get("id") == self._next_id:
                if "error" in answer:
                    raise BrowserError(f"{method}: {answer['error']}")
                return answer.get("result", {})

    def open(self, url: str) -> None:
        """Open ``url`` in a new page and attach to it."""
        target = self.command("Target.createTarget", session=False, url=url)["targetId"]
        self._session = self.command("Target.attachToTarget", session=False,
                                     targetId=target, flatten=True)["sessionId"]
        self.command("Emulation.setDeviceMetricsOverride", width=self.width,
                     height=self.height, deviceScaleFactor=1, mobile=False)

    def screenshot(self) -> bytes:
        """A PNG of the page as it is drawn now."""
        data = self.command("Page.captureScreenshot", format="png")["data"]
        return base64.b64decode(data)

    def shot_until(self, check: Callable[[np.ndarray], str], timeout: float = 120.0,
                   every: float = 2.0) -> bytes:
        """Screenshots until ``check(pixels)`` says nothing is missing ("" ), or time is up.

        ``check`` takes the (H, W, 3) RGB pixels and returns what is still missing, in
        words. Returns the first screenshot that passes; raises :class:`BrowserError` with
        the last verdict after ``timeout`` seconds.
        """
        deadline = time.monotonic() + timeout
        while True:
            png = self.screenshot()
            missing = check(png_pixels(png))
            if not missing:
                return png
            if time.monotonic() > deadline:
                raise BrowserError(f"the page did not draw what was asked within "
                                   f"{timeout:.0f} s: {missing}")
            time.sleep(every)


def colours_check(colours: Sequence[tuple[int, int, int]], min_pixels: int = 50,
                  tol: int = 12) -> Callable[[np.ndarray], str]:
    """A check for :meth:`Browser.shot_until`: ``min_pixels`` of each colour at least.

    With no colours: more than one colour on the page.
    """
    def check(pixels: np.ndarray) -> str:
        if not colours:
            return "" if len(np.unique(pixels.reshape(-1, 3), axis=0)) > 1 else \
                "a blank page"
        counts = [colour_count(pixels, c, tol) for c in colours]
        short = [f"{c}: {n} pixels" for c, n in zip(colours, counts, strict=True)
                 if n < min_pixels]
        return "; ".join(short)
    return check


def png_pixels(png: bytes) -> np.ndarray:
    """The (H, W, 3) uint8 RGB pixels of a PNG."""
    from PIL import Image  # pillow: a dependency of matplotlib and rerun-sdk
    with Image.open(io.BytesIO(png)) as image:
        return np.asarray(image.convert("RGB"))


def colour_count(pixels: np.ndarray, colour: tuple[int, int, int], tol: int = 12) -> int:
    """How many pixels are within ``tol`` of ``colour`` in every channel."""
    diff = np.abs(pixels.astype(np.int16) - np.asarray(colour, dtype=np.int16))
    return int(np.count_nonzero((diff <= tol).all(axis=-1)))


def _colour(text: str) -> tuple[int, int, int]:
    r, g, b = (int(v) for v in text.split(","))
    return r, g, b


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m phd_swarm.tools.browser_shot URL OUT.png``; see the module docstring."""
    parser = argparse.ArgumentParser(prog="browser_shot", description=__doc__.split("\n")[0])
    parser.add_argument("url")
    parser.add_argument("out", help="the PNG to write")
    parser.add_argument("--wait-colour", type=_colour, action="append", default=[],
                        metavar="R,G,B", help="wait until the page shows this colour "
                        "(repeatable)")
    parser.add_argument("--size", default="1600x1000", help="window WIDTHxHEIGHT")
    parser.add_argument("--timeout", type=float, default=120.0)
    parser.add_argument("--settle", type=float, default=0.0,
                        help="seconds to wait after the colours appear, then shoot again")
    args = parser.parse_args(argv)
    width, height = (int(v) for v in args.size.split("x"))
    try:
        with Browser(width, height) as browser:
            browser.open(args.url)
            png = browser.shot_until(colours_check(args.wait_colour),
                                     timeout=args.timeout)
            if args.settle:
                time.sleep(args.settle)
                png = browser.screenshot()
    except BrowserError as exc:
        print(f"browser_shot: {exc}", file=sys.stderr)
        return 1
    with open(args.out, "wb") as f:
        f.write(png)
    print(f"browser_shot: wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
