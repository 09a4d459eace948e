#!/usr/bin/env python3
"""isoforge view's latency as a user feels it: from a save of the scene to the page's first new pixels
(the coarse model on screen) and to the full model on screen, in headless Chromium (tests/view_test.py's
driver), for the bundled scenes and OpenSCAD examples. Each save appends a comment by rename, as an
editor would; the median of --saves saves is printed.

    /usr/bin/python3 bench/view_latency.py [--isoforge build/app/isoforge] [--saves 5]

OpenSCAD itself has no save-to-preview number to set beside these: its automatic reload polls the file
and renders a preview (OpenCSG) rather than a mesh; the row for OpenSCAD's own `openscad -o x.stl` export
of the same model is printed as the reference of a whole mesh.
"""
import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))
import view_test  # noqa: E402

MODELS = [
    ("examples/showcase.isf", os.path.join(HERE, "..", "examples", "showcase.isf")),
    ("examples/bracket.isf", os.path.join(HERE, "..", "examples", "bracket.isf")),
    ("OpenSCAD Basics/CSG.scad", "/usr/share/openscad/examples/Basics/CSG.scad"),
    ("OpenSCAD Basics/logo.scad", "/usr/share/openscad/examples/Basics/logo.scad"),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--isoforge", default=os.path.join(HERE, "..", "build", "app", "isoforge"))
    ap.add_argument("--saves", type=int, default=5)
    args = ap.parse_args()
    view_test.ISOFORGE = os.path.abspath(args.isoforge)
    print("| model | first model on screen (median) | full model on screen (median) | full model's triangles | "
          "openscad -o .stl |")
    print("|---|---|---|---|---|")
    for name, src in MODELS:
        if not os.path.exists(src):
            print("| %s | (missing) | | | |" % name)
            continue
        tmp = tempfile.mkdtemp(prefix="isoforge-view-bench-")
        try:
            path = os.path.join(tmp, os.path.basename(src))
            shutil.copy(src, path)
            text = open(path).read()
            v = view_test.View(path)
            chrome = view_test.Chromium(800, 600, tmp)
            try:
                chrome.open(v.url)
                full = lambda: chrome.eval("window.isoforgeView ? isoforgeView.shownStage : ''") == "full"
                if not view_test.wait_for(full, 120, 0.05):
                    print("| %s | (no model: %s) | | | |" % (name, v.state().get("error", "")[:80]))
                    continue
                firsts, fulls = [], []
                for i in range(args.saves):
                    model = chrome.eval("isoforgeView.shownModel")
                    t0 = time.monotonic()
                    view_test.save_by_rename(path, text + "\n// save %d\n" % i)
                    t1 = view_test.wait_for(lambda: chrome.eval("isoforgeView.shownModel") > model and time.monotonic(),
                                            120, 0.005)
                    t2 = view_test.wait_for(lambda: chrome.eval("isoforgeView.shownModel") > model and
                                            chrome.eval("isoforgeView.shownStage") == "full" and time.monotonic(),
                                            120, 0.005)
                    firsts.append(t1 - t0)
                    fulls.append(t2 - t0)
                    time.sleep(0.3)
                tris = v.state()["info"]["triangles"]
            finally:
                chrome.close()
                v.stop()
            ref = ""
            if src.endswith(".scad") and shutil.which("openscad"):
                t0 = time.monotonic()
                subprocess.run(["openscad", "-o", os.path.join(tmp, "x.stl"), path], capture_output=True)
                ref = "%.2f s" % (time.monotonic() - t0)
            print("| %s | %.3f s | %.3f s | %s | %s |" % (name, statistics.median(firsts), statistics.median(fulls),
                                                           "{:,}".format(tris), ref), flush=True)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
