"""Open a page in headless Chromium over the DevTools protocol (a pipe, no extra packages).

Collects console errors, uncaught exceptions, failed loads and log errors, reports every
image's load state and takes a full-page screenshot.
"""

import base64
import json
import os
import subprocess
import tempfile
import time

FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--remote-debugging-pipe",
]


class Browser:
    """One headless Chromium with a fresh profile, driven through fds 3 (in) and 4 (out)."""

    def __init__(self, chromium, timeout=120.0):
        self.timeout = timeout
        self.profile = tempfile.TemporaryDirectory(prefix="chromium-profile-")
        to_child_r, self._w = os.pipe()
        self._r, from_child_w = os.pipe()

        def fds():
            os.dup2(to_child_r, 3)
            os.dup2(from_child_w, 4)

        self.proc = subprocess.Popen(
            [chromium, *FLAGS, f"--user-data-dir={self.profile.name}", "about:blank"],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            # close_fds runs after preexec_fn in the child: keep 3 and 4 too.
            pass_fds=(3, 4, to_child_r, from_child_w),
            preexec_fn=fds,
        )
        os.close(to_child_r)
        os.close(from_child_w)
        self._buf = b""
        self._id = 0
        self.events = []

    def _read_message(self, deadline):
        import select

        while b"\0" not in self._buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError("no answer from Chromium")
            ready, _, _ = select.select([self._r], [], [], left)
            if ready:
                chunk = os.read(self._r, 1 << 20)
                if not chunk:
                    raise RuntimeError("Chromium closed the DevTools pipe")
                self._buf += chunk
        raw, self._buf = self._buf.split(b"\0", 1)
        return json.loads(raw)

    def send(self, method, params=None, session=None):
        self._id += 1
        msg = {"id": self._id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self._w, json.dumps(msg).encode() + b"\0")
        deadline = time.monotonic() + self.timeout
        while True:
            m = self._read_message(deadline)
            if m.get("id") == self._id:
                if "error" in m:
                    raise RuntimeError(f"{method}: {m['error']}")
                return m.get("result", {})
            self.events.append(m)

    def wait_for(self, method, deadline):
        for k, m in enumerate(self.events):
            if m.get("method") == method:
                return self.events.pop(k)
        while True:
            m = self._read_message(deadline)
            if m.get("method") == method:
                return m
            self.events.append(m)

    def close(self):
        try:
            os.write(self._w, json.dumps({"id": 0, "method": "Browser.close"}).encode() + b"\0")
            self.proc.wait(timeout=20)
        except Exception:
            self.proc.kill()
            self.proc.wait()
        os.close(self._w)
        os.close(self._r)
        self.profile.cleanup()


def _open(b, url, width, domains):
    """Open ``url`` in a new tab of ``b`` at ``width`` px with ``domains`` enabled; returns the session."""
    target = b.send("Target.createTarget", {"url": "about:blank"})["targetId"]
    session = b.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
    for domain in domains:
        b.send(f"{domain}.enable", session=session)
    b.send(
        "Emulation.setDeviceMetricsOverride",
        {"width": width, "height": 900, "deviceScaleFactor": 1, "mobile": False},
        session=session,
    )
    b.send("Page.navigate", {"url": url}, session=session)
    b.wait_for("Page.loadEventFired", time.monotonic() + b.timeout)
    return session


def inspect_page(chromium, url, width=1100):
    """Load ``url``; returns (problems, images, screenshot PNG bytes).

    ``problems`` lists console errors, uncaught exceptions, failed requests and log entries
    of level error; ``images`` is ``[(complete, naturalWidth, src prefix)]`` per <img>.
    """
    b = Browser(chromium)
    try:
        session = _open(b, url, width, ("Page", "Runtime", "Log", "Network"))
        images = b.send(
            "Runtime.evaluate",
            {
                "expression": "JSON.stringify(Array.from(document.images).map(i => [i.complete, i.naturalWidth, i.src.slice(0, 22)]))",
                "returnByValue": True,
            },
            session=session,
        )["result"]["value"]
        shot = b.send(
            "Page.captureScreenshot", {"format": "png", "captureBeyondViewport": True}, session=session
        )
        problems = []
        for m in b.events:
            meth, p = m.get("method"), m.get("params", {})
            if meth == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
                problems.append(f"console.{p['type']}: {[a.get('value') for a in p.get('args', [])]}")
            elif meth == "Runtime.exceptionThrown":
                problems.append(f"exception: {p.get('exceptionDetails', {}).get('text')}")
            elif meth == "Log.entryAdded" and p.get("entry", {}).get("level") == "error":
                problems.append(f"log: {p['entry'].get('text')} {p['entry'].get('url', '')}")
            elif meth == "Network.loadingFailed":
                problems.append(f"failed load: {p.get('errorText')}")
        return problems, [tuple(x) for x in json.loads(images)], base64.b64decode(shot["data"])
    finally:
        b.close()


def evaluate_page(chromium, url, expression, width=1100):
    """Load ``url`` and return (the JSON value of ``expression``, a full-page screenshot PNG)."""
    b = Browser(chromium)
    try:
        session = _open(b, url, width, ("Page",))
        value = b.send(
            "Runtime.evaluate",
            {"expression": f"JSON.stringify({expression})", "returnByValue": True},
            session=session,
        )["result"]["value"]
        shot = b.send(
            "Page.captureScreenshot", {"format": "png", "captureBeyondViewport": True}, session=session
        )
        return json.loads(value), base64.b64decode(shot["data"])
    finally:
        b.close()
