#!/usr/bin/env python3
"""isoforge view end to end: the server over loopback (page, model, state, events), the watcher through
it (saves in place and by rename, delete and re-create, an included file, a syntax error then its fix,
a .scad's include<>), a port in use, and the page itself in headless Chromium (a model appears and
matches `isoforge render` of the same camera; a save updates it while the camera stays where the user
dragged it; an error is shown over the last good model).

    /usr/bin/python3 tests/view_test.py ISOFORGE [--no-browser] [--bench]

Every wait is bounded; the processes it starts are stopped however it ends. --bench prints the
save-to-first-model and save-to-full-model latencies (bench/view_latency.py runs it on the bundled scenes).
"""
import base64
import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request

ISOFORGE = None  # set by main() from the command line, or by a script that imports this one (bench/)
BROWSER = "--no-browser" not in sys.argv
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        failures.append(what)


def wait_for(pred, seconds, step=0.02):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        v = pred()
        if v:
            return v
        time.sleep(step)
    return pred()


def get(url, timeout=5):
    with urllib.request.urlopen(url, timeout=timeout) as r:
        return r.status, r.headers.get("Content-Type", ""), r.read()


def save_by_rename(path, text):
    tmp = os.path.join(os.path.dirname(path), "." + os.path.basename(path) + ".tmp")
    with open(tmp, "w") as f:
        f.write(text)
    os.rename(tmp, path)


def save_in_place(path, text):
    with open(path, "w") as f:
        f.write(text)


class View:
    """isoforge view on a file, on a free port; stopped (SIGINT, then SIGKILL) by stop()."""

    def __init__(self, *args):
        self.p = subprocess.Popen([ISOFORGE, "view", *args, "--port", "0"], stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True)
        line = self.p.stdout.readline()
        m = re.match(r"isoforge view: (http://127\.0\.0\.1:\d+/)", line)
        if not m:
            self.stop()
            raise RuntimeError("no address printed: " + line + self.p.stderr.read())
        self.url = m.group(1)

    def state(self):
        return json.loads(get(self.url + "state")[2])

    def wait_model(self, after_generation=0, stage="full", seconds=60):
        """The state once a build after `after_generation` has finished (a model of `stage`, or an error)."""
        def done():
            s = self.state()
            if s["generation"] > after_generation and not s["building"] and (s.get("stage") == stage or "error" in s):
                return s
            return None
        return wait_for(done, seconds)

    def stop(self):
        if self.p.poll() is None:
            self.p.send_signal(signal.SIGINT)
            try:
                self.p.wait(10)
            except subprocess.TimeoutExpired:
                self.p.kill()
                self.p.wait()
        return self.p.returncode


SCENE = """camera(eye = [6, -8, 5], target = [0, 0, 0.4], fov = 30);
background(top = [0.3, 0.4, 0.6], bottom = [0.3, 0.4, 0.6]);
material(color = [0.8, 0.25, 0.1]) difference() { cube(2, center = true); sphere(1.3); }
translate([0, 0, 1.4]) sphere(R);
"""


def scene(r, extra=""):
    return SCENE.replace("sphere(R)", "sphere(%g)" % r) + extra


def server_tests(tmp):
    path = os.path.join(tmp, "view.isf")
    part = os.path.join(tmp, "part.stl")
    subprocess.run([ISOFORGE, "primitive", "icosphere", "--resolution", "2", "-o", part], check=True,
                   stdout=subprocess.DEVNULL)
    save_in_place(path, scene(0.6, 'translate([3, 0, 0]) mesh("part.stl");\n'))
    v = View(path, "--resolution", "64", "--coarse", "16")
    try:
        s = v.wait_model()
        check(s and s.get("stage") == "full" and s["info"]["check"]["closed"], "the first build gives a closed full model")
        check(s and sorted(os.path.basename(f) for f in s["files"]) == ["part.stl", "view.isf"],
              "the scene and the mesh it reads are watched: %s" % (s and s["files"]))
        st, ctype, body = get(v.url)
        check(st == 200 and "text/html" in ctype and b"viewer.js" in body, "GET / is the page")
        st, ctype, body = get(v.url + "viewer.js")
        check(st == 200 and b"EventSource" in body, "GET /viewer.js")
        for f in ["three.min.js", "OrbitControls.js", "GLTFLoader.js"]:
            st, _, body = get(v.url + "three/" + f)
            check(st == 200 and len(body) > 1000, "GET /three/" + f)
        st, ctype, body = get(v.url + "model.glb")
        check(st == 200 and body[:4] == b"glTF" and ctype == "model/gltf-binary", "GET /model.glb is a .glb")
        try:
            get(v.url + "no/such/file")
            check(False, "an unknown path is 404")
        except urllib.error.HTTPError as e:
            check(e.code == 404, "an unknown path is 404")
        # The event stream sends the state at once.
        with urllib.request.urlopen(v.url + "events", timeout=5) as r:
            check("text/event-stream" in r.headers.get("Content-Type", ""), "/events is an event stream")
            first = r.readline().decode() + r.readline().decode()
            check(first.startswith("event: state\ndata: {") and '"generation"' in first, "the stream starts with the state")

        # Many tabs open at once (each event stream holds a server thread): the server still answers.
        streams = [urllib.request.urlopen(v.url + "events", timeout=5) for _ in range(12)]
        for r in streams:
            r.readline()
        t0 = time.monotonic()
        st, _, _ = get(v.url + "state", timeout=5)
        check(st == 200 and time.monotonic() - t0 < 2, "with 12 event streams open the server still answers (%.3f s)"
              % (time.monotonic() - t0))
        for r in streams:
            r.close()

        def rebuilt_after(change, what, stage="full"):
            g = v.state()["generation"]
            t0 = time.monotonic()
            change()
            s = v.wait_model(g, stage, 30)
            check(s is not None and s["generation"] > g and "error" not in s,
                  "%s: rebuilt (%.2f s)" % (what, time.monotonic() - t0))
            return s

        s = rebuilt_after(lambda: save_in_place(path, scene(0.7, 'translate([3, 0, 0]) mesh("part.stl");\n')),
                          "a save in place")
        s = rebuilt_after(lambda: save_by_rename(path, scene(0.8, 'translate([3, 0, 0]) mesh("part.stl");\n')),
                          "a save by rename")

        def delete_recreate():
            os.remove(path)
            time.sleep(0.15)
            save_in_place(path, scene(0.9, 'translate([3, 0, 0]) mesh("part.stl");\n'))
        s = rebuilt_after(delete_recreate, "delete and re-create")
        before = s and s["info"]["triangles"]
        s = rebuilt_after(lambda: subprocess.run([ISOFORGE, "primitive", "cube", "-o", part], check=True,
                                                 stdout=subprocess.DEVNULL), "the included mesh changed")
        check(s and s["info"]["triangles"] != before, "the included file's change is in the model")
        # A syntax error: the error, with file:line:column; the last good model stays.
        g, model = v.state()["generation"], v.state()["model"]
        save_by_rename(path, scene(0.9, "cube([1, 2);\n"))
        s = v.wait_model(g, "full", 30)
        check(s and "error" in s and re.search(r"view\.isf:5:\d+", s["error"]) and s["model"] == model,
              "a syntax error is reported with file:line:column, the last model kept: %s" % (s and s.get("error")))
        s = rebuilt_after(lambda: save_by_rename(path, scene(0.5)), "the fix")
        check(s and "error" not in s and s["model"] > model, "the fix clears the error")
        check(s and [os.path.basename(f) for f in s["files"]] == ["view.isf"], "the mesh no longer read is no longer watched")
        # Two saves in a row (each its own change): the model shown is the last one's, as the command line
        # makes it. (Cancelling a build mid-way is test_view's Builder.ACoarseLookThenTheFullModel.)
        g = v.state()["generation"]
        save_by_rename(path, scene(0.55))
        time.sleep(0.3)
        save_by_rename(path, scene(0.65))
        s = v.wait_model(g + 1, "full", 30)
        ply = os.path.join(tmp, "last.ply")
        out = subprocess.run([ISOFORGE, "mesh", path, "--resolution", "64", "-o", ply], capture_output=True,
                             text=True).stdout
        m = re.search(r"([\d,]+) triangles", out)
        check(s and "error" not in s and m and s["info"]["triangles"] == int(m.group(1).replace(",", "")),
              "two saves in a row: the last one's model (%s triangles, the command line's %s)"
              % (s and s["info"]["triangles"], m and m.group(1)))
        # A save while a slow build runs cancels it: the next build starts at once, and its model is shown.
        v2 = View(path, "--resolution", "400", "--coarse", "0")
        try:
            s = v2.wait_model(0, "full", 60)
            g = s["generation"]
            save_by_rename(path, scene(0.6))
            busy = wait_for(lambda: v2.state()["building"] and v2.state()["generation"] > g, 10, 0.005)
            save_by_rename(path, scene(0.62))
            s = v2.wait_model(g + 1, "full", 60)
            check(bool(busy) and s and s["cancelled"] >= 1 and "error" not in s,
                  "a save during a build cancels it (%s cancelled)" % (s and s["cancelled"]))
        finally:
            v2.stop()
        # The port in use: a clear message, exit 1.
        port = v.url.rsplit(":", 1)[1].strip("/")
        r = subprocess.run([ISOFORGE, "view", path, "--port", port], capture_output=True, text=True, timeout=20)
        check(r.returncode == 1 and "in use" in r.stderr, "a port in use: exit 1, '%s'" % r.stderr.strip())
    finally:
        rc = v.stop()
    check(rc == 0, "Ctrl-C stops it with status 0 (%s)" % rc)
    r = subprocess.run([ISOFORGE, "view"], capture_output=True, text=True, timeout=20)
    check(r.returncode == 2, "no input: exit 2")


def scad_tests(tmp):
    if not shutil.which("openscad"):
        print("skip .scad: openscad is not installed")
        return
    inc = os.path.join(tmp, "inc.scad")
    main = os.path.join(tmp, "model.scad")
    save_in_place(inc, "module part() { cube(2, center = true); }\n")
    save_in_place(main, "include <inc.scad>\npart();\ntranslate([0, 0, 1]) sphere(0.8, $fn = 24);\n")
    v = View(main, "--resolution", "48", "--coarse", "0")
    try:
        s = v.wait_model()
        check(s and "error" not in s and sorted(os.path.basename(f) for f in s["files"]) == ["inc.scad", "model.scad"],
              ".scad: the model and its include<> are watched: %s" % (s and s.get("files")))
        g, tri = s["generation"], s["info"]["triangles"]
        save_by_rename(inc, "module part() { cylinder(r = 1, h = 2, center = true, $fn = 32); }\n")
        s = v.wait_model(g, "full", 30)
        check(s and "error" not in s and s["info"]["triangles"] != tri, ".scad: a change to the included file rebuilds")
        g = s["generation"]
        save_by_rename(inc, "module part() { cube(2 }\n")
        s = v.wait_model(g, "full", 30)
        check(s and "error" in s and "inc.scad" in s["error"], ".scad: OpenSCAD's error names the included file: %s"
              % (s and s.get("error")))
        g = s["generation"]
        save_by_rename(inc, "module part() { cube(1.5, center = true); }\n")
        s = v.wait_model(g, "full", 30)
        check(s and "error" not in s, ".scad: fixing the included file recovers")
    finally:
        v.stop()


class Chromium:
    """Headless Chromium driven over the DevTools protocol on a pipe (--remote-debugging-pipe): no
    WebDriver, no network port. WebGL through SwiftShader (no GPU needed)."""

    def __init__(self, width, height, tmp):
        exe = shutil.which("chromium") or shutil.which("chromium-browser")
        if not exe:
            raise RuntimeError("chromium is not installed (Debian package chromium)")
        cmd_r, self.cmd_w = os.pipe()
        self.res_r, res_w = os.pipe()

        def fds():
            import fcntl
            r, w = fcntl.fcntl(cmd_r, fcntl.F_DUPFD, 10), fcntl.fcntl(res_w, fcntl.F_DUPFD, 10)  # clear of 3 and 4
            os.dup2(r, 3)
            os.dup2(w, 4)
        self.p = subprocess.Popen(
            [exe, "--headless=new", "--remote-debugging-pipe", "--no-sandbox", "--no-first-run",
             "--disable-dev-shm-usage", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
             "--ignore-gpu-blocklist", "--hide-scrollbars", "--window-size=%d,%d" % (width, height),
             "--user-data-dir=" + os.path.join(tmp, "chromium-profile"), "about:blank"],
            preexec_fn=fds, close_fds=False, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(cmd_r)
        os.close(res_w)
        self.buf = b""
        self.next_id = 0
        self.session = None
        self.width, self.height = width, height

    def call(self, method, params=None, session=True, timeout=30):
        self.next_id += 1
        msg = {"id": self.next_id, "method": method, "params": params or {}}
        if session and self.session:
            msg["sessionId"] = self.session
        os.write(self.cmd_w, json.dumps(msg).encode() + b"\0")
        end = time.monotonic() + timeout
        import select
        while True:
            while b"\0" in self.buf:
                raw, self.buf = self.buf.split(b"\0", 1)
                reply = json.loads(raw)
                if reply.get("id") == self.next_id:
                    if "error" in reply:
                        raise RuntimeError("%s: %s" % (method, reply["error"]))
                    return reply.get("result", {})
            left = end - time.monotonic()
            if left <= 0 or not select.select([self.res_r], [], [], left)[0]:
                raise RuntimeError(method + ": no answer from chromium")
            chunk = os.read(self.res_r, 1 << 20)
            if not chunk:
                raise RuntimeError(method + ": chromium closed the pipe")
            self.buf += chunk

    def open(self, url):
        target = self.call("Target.createTarget", {"url": "about:blank"}, session=False)["targetId"]
        self.session = self.call("Target.attachToTarget", {"targetId": target, "flatten": True},
                                 session=False)["sessionId"]
        self.call("Emulation.setDeviceMetricsOverride",
                  {"width": self.width, "height": self.height, "deviceScaleFactor": 1, "mobile": False})
        self.call("Page.navigate", {"url": url})

    def eval(self, expr):
        r = self.call("Runtime.evaluate", {"expression": expr, "returnByValue": True})
        if "exceptionDetails" in r:
            raise RuntimeError(expr + ": " + json.dumps(r["exceptionDetails"])[:400])
        return r["result"].get("value")

    def screenshot(self):
        return base64.b64decode(self.call("Page.captureScreenshot", {"format": "png"})["data"])

    def drag(self, x0, y0, x1, y1, steps=10):
        self.call("Input.dispatchMouseEvent", {"type": "mouseMoved", "x": x0, "y": y0})
        self.call("Input.dispatchMouseEvent", {"type": "mousePressed", "x": x0, "y": y0, "button": "left",
                                               "buttons": 1, "clickCount": 1})
        for i in range(1, steps + 1):
            x, y = x0 + (x1 - x0) * i / steps, y0 + (y1 - y0) * i / steps
            self.call("Input.dispatchMouseEvent", {"type": "mouseMoved", "x": x, "y": y, "button": "left",
                                                   "buttons": 1})
        self.call("Input.dispatchMouseEvent", {"type": "mouseReleased", "x": x1, "y": y1, "button": "left",
                                               "buttons": 0, "clickCount": 1})

    def close(self):
        try:
            self.call("Browser.close", session=False, timeout=5)
        except Exception:
            pass
        try:
            self.p.wait(5)
        except subprocess.TimeoutExpired:
            self.p.kill()
            self.p.wait()


def silhouette(png):
    """Pixels that differ from the (uniform) background, which the top-left corner shows."""
    import numpy as np
    from PIL import Image
    a = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    return np.abs(a - a[0, 0]).sum(axis=2) > 60


def browser_tests(tmp, bench):
    import numpy as np
    width, height = 640, 480
    path = os.path.join(tmp, "browser.isf")
    save_in_place(path, scene(0.6))
    v = View(path, "--resolution", "96", "--coarse", "24")
    chrome = None
    try:
        chrome = Chromium(width, height, tmp)
        chrome.open(v.url)
        shown = lambda: chrome.eval("window.isoforgeView ? [isoforgeView.shownModel, isoforgeView.shownStage] : null")
        ok = wait_for(lambda: (shown() or [0, ""])[1] == "full", 60, 0.1)
        check(bool(ok), "the page shows the full model (%s)" % (shown(),))
        check(chrome.eval("document.getElementById('input').textContent").endswith("browser.isf"),
              "the panel names the input")
        check("closed, manifold, oriented" in chrome.eval("document.getElementById('summary').textContent"),
              "the panel shows the check")
        cam0 = chrome.eval("isoforgeView.camera()")
        check([round(x, 4) for x in cam0["position"]] == [6, -8, 5] and cam0["fov"] == 30,
              "the first view is the scene's camera: %s" % cam0)
        # The page against isoforge render of the same camera: their silhouettes.
        chrome.eval("document.getElementById('panel').style.display = document.getElementById('help').style.display"
                    " = 'none'; 1")
        time.sleep(0.3)
        page = chrome.screenshot()
        ref = os.path.join(tmp, "ref.png")
        subprocess.run([ISOFORGE, "-q", "render", path, "--size", "%dx%d" % (width, height), "--resolution", "96",
                        "-o", ref], check=True)
        a, b = silhouette(page), silhouette(open(ref, "rb").read())
        iou = (a & b).sum() / max(1, (a | b).sum())
        if iou < 0.97 and os.environ.get("ISOFORGE_VIEW_TEST_KEEP"):  # a directory for the two pictures
            open(os.path.join(os.environ["ISOFORGE_VIEW_TEST_KEEP"], "page.png"), "wb").write(page)
            shutil.copy(ref, os.environ["ISOFORGE_VIEW_TEST_KEEP"])
        check(iou >= 0.97 and a.sum() > 0.05 * a.size,
              "the page's picture has the silhouette of isoforge render's (IoU %.4f, %.1f%% of the pixels)"
              % (iou, 100 * a.mean()))
        # Orbit with the mouse, then save: the model changes, the camera stays.
        chrome.drag(320, 240, 420, 260)
        cam1 = chrome.eval("isoforgeView.camera()")
        check(cam1["position"] != cam0["position"], "dragging orbits the camera")
        model = chrome.eval("isoforgeView.shownModel")
        t0 = time.monotonic()
        save_by_rename(path, scene(0.9))
        first = wait_for(lambda: chrome.eval("isoforgeView.shownModel") > model and time.monotonic(), 30, 0.01)
        full = wait_for(lambda: chrome.eval("isoforgeView.shownModel") > model and
                        chrome.eval("isoforgeView.shownStage") == "full" and time.monotonic(), 30, 0.01)
        check(bool(first) and bool(full), "a save updates the page (first pixels %.2f s, full model %.2f s)"
              % ((first or t0) - t0, (full or t0) - t0))
        if bench:
            print("latency: save to first model %.3f s, to full model %.3f s" % (first - t0, full - t0))
        check(chrome.eval("isoforgeView.camera()") == cam1, "the camera stays where the user left it")
        # An error is shown over the last good model.
        model = chrome.eval("isoforgeView.shownModel")
        save_by_rename(path, scene(0.9, "sphere(;\n"))
        err = wait_for(lambda: chrome.eval("isoforgeView.errorShown"), 30, 0.05)
        check(bool(err) and "browser.isf:5:" in err and
              chrome.eval("getComputedStyle(document.getElementById('error')).display") == "block" and
              chrome.eval("isoforgeView.shownModel") == model,
              "a syntax error is shown over the last good model: %s" % err)
        save_by_rename(path, scene(0.7))
        check(bool(wait_for(lambda: not chrome.eval("isoforgeView.errorShown") and
                            chrome.eval("isoforgeView.shownModel") > model, 30, 0.05)),
              "the fix removes the error and shows the new model")
    finally:
        if chrome:
            chrome.close()
        v.stop()


def main():
    global ISOFORGE
    if len(sys.argv) < 2 or sys.argv[1].startswith("-"):
        print(__doc__)
        return 2
    ISOFORGE = os.path.abspath(sys.argv[1])
    tmp = tempfile.mkdtemp(prefix="isoforge-view-test-")
    try:
        if "--bench" not in sys.argv:
            server_tests(tmp)
            scad_tests(tmp)
        if BROWSER or "--bench" in sys.argv:
            browser_tests(tmp, "--bench" in sys.argv)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print("%d failed" % len(failures) if failures else "all passed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
