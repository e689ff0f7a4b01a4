#!/usr/bin/env python3
"""Browser test of `quadtune report`: a tiny tuning run, its report, opened from disk by headless
Chromium (Debian's). Checks that the page raises no error, that the charts and the 3-D canvas
render (screenshot regions are not blank), and that scrubbing the replay moves the drone to the
logged position of the flight.

    report_browser_test.py QUADTUNE_BINARY EXPERIMENT_YAML

Exit status 77 (ctest SKIP_RETURN_CODE) when no chromium is installed; 0 pass; 1 fail.
Python standard library plus python3-pil (PNG decoding).
"""

import csv
import glob
import html.parser
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile

SKIP = 77


class Page(html.parser.HTMLParser):
    """Attributes of the elements the test reads from Chromium's --dump-dom output."""

    def __init__(self):
        super().__init__()
        self.attrs, self.errors, self._in_errors = {}, "", False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "body":
            self.attrs["body"] = a
        if a.get("id") == "qt-drone-pos":
            self.attrs["pos"] = a
        self._in_errors = a.get("id") == "qt-errors"

    def handle_endtag(self, tag):
        self._in_errors = False

    def handle_data(self, data):
        if self._in_errors:
            self.errors += data


def chromium():
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    return None


def browse(browser, profile, url, extra):
    """Runs headless Chromium on `url`; returns (stdout, stderr)."""
    cmd = [browser, "--headless", "--no-sandbox", "--use-angle=swiftshader",
           "--enable-unsafe-swiftshader", "--enable-logging=stderr", "--v=0",
           "--force-device-scale-factor=1", "--hide-scrollbars", f"--user-data-dir={profile}",
           "--virtual-time-budget=10000", "--window-size=1300,3600"] + extra + [url]
    # A guard against a hung browser only; the test has no speed requirement.
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=1500)
    return done.stdout, done.stderr


def check(condition, message):
    if not condition:
        print("FAIL:", message)
        sys.exit(1)
    print("ok:", message)


def console_errors(stderr):
    return [line for line in stderr.splitlines()
            if ":CONSOLE" in line and ("Uncaught" in line or "Error" in line)]


def logged_position(flight_csv, t):
    """The drone position of flight.csv at time t, interpolated linearly as the page does."""
    rows = [(float(r["t"]), float(r["x"]), float(r["y"]), float(r["z"]))
            for r in csv.DictReader(open(flight_csv))]
    for a, b in zip(rows, rows[1:]):
        if a[0] <= t <= b[0]:
            w = (t - a[0]) / (b[0] - a[0])
            return [a[k] + w * (b[k] - a[k]) for k in (1, 2, 3)]
    return list(rows[-1][1:])


def main():
    quadtune, experiment = sys.argv[1], sys.argv[2]
    browser = chromium()
    if browser is None:
        print("SKIP: no chromium on PATH (scripts/setup.sh installs Debian's chromium)")
        return SKIP
    from PIL import Image  # Debian: python3-pil

    work = tempfile.mkdtemp(prefix="quadtune_report_test_")
    run = os.path.join(work, "run")
    subprocess.run([quadtune, "--log-level", "warn", "run", "--no-plot", experiment, "--out", run], check=True)
    subprocess.run([quadtune, "--log-level", "warn", "report", run, "--flights", "1"], check=True)
    page = os.path.join(run, "report.html")
    check(os.path.isfile(page), "report.html written")
    text = open(page, encoding="utf-8").read()
    check("<script src=" not in text and "<link " not in text,
          "the page loads nothing from outside itself")
    flights = glob.glob(os.path.join(run, "report_flights", "*", "flight.csv"))
    check(len(flights) == 1, "one stored flight flown again for the replay")
    duration = float(list(csv.DictReader(open(flights[0])))[-1]["t"])

    url = "file://" + os.path.abspath(page)
    positions = {}
    times = [round(0.25 * duration, 3), round(0.6 * duration, 3)]
    for t in times:
        dom, err = browse(browser, os.path.join(work, "profile"), f"{url}#t={t:.3f}",
                          ["--dump-dom"])
        parsed = Page()
        parsed.feed(dom)
        body = parsed.attrs.get("body", {})
        check(body.get("data-ready") == "1", f"the page's script ran to the end (t = {t:.2f})")
        check(parsed.errors.strip() == "", f"no error on the page: {parsed.errors.strip()!r}")
        check(not console_errors(err), f"no console error: {console_errors(err)}")
        pos = parsed.attrs["pos"]
        shown = [float(pos["data-x"]), float(pos["data-y"]), float(pos["data-z"])]
        logged = logged_position(flights[0], t)
        # The page holds the log rounded to 1 mm and 1 ms.
        check(all(abs(a - b) < 2e-3 for a, b in zip(shown, logged)),
              f"drone at t = {t:.2f} s is where the flight log puts it: {shown} vs {logged}")
        positions[t] = shown
    a, b = positions.values()
    check(sum((x - y) ** 2 for x, y in zip(a, b)) ** 0.5 > 0.5, "scrubbing moves the drone")
    boxes = json.loads(body["data-boxes"])

    shots = []
    for t in times:
        png = os.path.join(work, f"shot_{t:.2f}.png")
        _, err = browse(browser, os.path.join(work, "profile"), f"{url}#t={t:.3f}",
                        [f"--screenshot={png}"])
        check(os.path.isfile(png), f"screenshot at t = {t:.2f} s")
        check(not console_errors(err), "no console error while rendering")
        shots.append(Image.open(png).convert("RGB"))
    # Axes, grid lines and labels are grey; data (lines, markers, bars, obstacles) is coloured.
    # An empty chart or a blank canvas has no coloured pixel.
    for name in ("qt-convergence", "qt-finals", "qt-importance", "qt-slices", "qt-parcoords",
                 "qt-scene"):
        x, y, w, h = boxes[name]
        region = list(shots[0].crop((x, y, x + w, y + h)).getdata())
        coloured = sum(1 for p in region if max(p) - min(p) > 60)
        spread = statistics.pstdev([sum(p) / 3 for p in region])
        check(coloured > 40 and spread > 3.0,
              f"{name} is drawn ({coloured} coloured pixels, grey-level spread {spread:.1f})")
    x, y, w, h = boxes["qt-scene"]
    first = list(shots[0].convert("L").crop((x, y, x + w, y + h)).getdata())
    second = list(shots[1].convert("L").crop((x, y, x + w, y + h)).getdata())
    changed = sum(1 for p, q in zip(first, second) if abs(p - q) > 10)
    check(changed > 50, f"the 3-D view changes when the replay is scrubbed ({changed} pixels)")
    shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
