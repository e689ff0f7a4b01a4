#!/usr/bin/env python3
"""Browser test of `quadtune report`: a small tuning run (EXPERIMENT_YAML with three methods,
two repeats, eight flights and three held-out maps), its figures, tuning.md and report, opened
from disk by headless Chromium (Debian's). Checks that the page raises no error; that its
held-out validation table and tuned-parameter table hold, cell for cell, what tuning.md holds;
that the methods carry one name (tuning.md's) and one colour (experiments/plot/quadtune_methods)
and the Default's final value is tuning.md's; that the evaluation table counts the store's rows
and states; that the charts and the 3-D canvas render (screenshot regions are not blank); and
that scrubbing the replay moves the drone to the logged position of the flight.

    report_browser_test.py QUADTUNE_BINARY EXPERIMENT_YAML

Exit status 77 (ctest SKIP_RETURN_CODE) when no chromium is installed; 0 pass; 1 fail.
Python 3 with python3-pil (PNG decoding) and python3-yaml.
"""

import csv
import glob
import html.parser
import json
import os
import shutil
import sqlite3
import statistics
import subprocess
import sys
import tempfile

SKIP = 77
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "experiments", "plot"))
import quadtune_methods  # noqa: E402  (the one naming and colouring of the methods)


class Page(html.parser.HTMLParser):
    """Attributes of the elements the test reads from Chromium's --dump-dom output."""

    def __init__(self):
        super().__init__()
        self.attrs, self.errors, self._in_errors = {}, "", False
        self.texts = {}     # id -> text of elements whose text the test reads
        self.tables = {}    # table id -> rows (head first) of cell texts
        self._table = self._cell = self._text = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "body":
            self.attrs["body"] = a
        if a.get("id") == "qt-drone-pos":
            self.attrs["pos"] = a
        if a.get("id") in ("qt-eval-count", "qt-importance-caption", "qt-subtitle"):
            self._text = a["id"]
            self.texts[self._text] = ""
        if tag == "table" and a.get("id"):
            self._table = a["id"]
            self.tables[self._table] = []
            self.attrs[self._table] = a
        if self._table and tag == "tr":
            self.tables[self._table].append([])
        if self._table and tag in ("td", "th"):
            self._cell = ""
        self._in_errors = a.get("id") == "qt-errors"

    def handle_endtag(self, tag):
        self._in_errors = False
        if tag == "p":
            self._text = None
        if tag == "table":
            self._table = None
        if self._table and tag in ("td", "th") and self._cell is not None:
            self.tables[self._table][-1].append(self._cell.strip())
            self._cell = None

    def handle_data(self, data):
        if self._in_errors:
            self.errors += data
        if self._cell is not None:
            self._cell += data
        if self._text:
            self.texts[self._text] += data


def markdown_tables(path):
    """The Markdown tables of a file: [rows of cell texts] each, the separator row left out."""
    tables, current = [], None
    for line in open(path, encoding="utf-8"):
        line = line.strip()
        if line.startswith("|") and line.endswith("|"):
            cells = [c.strip() for c in line[1:-1].split("|")]
            if all(set(c) <= set("-:") and c for c in cells):
                continue
            if current is None:
                current = []
                tables.append(current)
            current.append(cells)
        else:
            current = None
    return tables


def table_starting(tables, first_heads):
    """The table whose head row starts with `first_heads`."""
    found = [t for t in tables if t[0][:len(first_heads)] == first_heads]
    check(len(found) == 1, f"tuning.md has one table headed {first_heads}")
    return found[0]


def page_data(page):
    """The JSON data of the page."""
    text = open(page, encoding="utf-8").read()
    start = text.index('id="qt-data">') + len('id="qt-data">')
    return json.loads(text[start:text.index("</script>", start)])


def small_experiment(tiny, path):
    """EXPERIMENT_YAML grown to three methods, two repeats, eight flights, three held-out maps."""
    import yaml  # Debian: python3-yaml
    with open(tiny, encoding="utf-8") as fh:
        doc = yaml.safe_load(fh)
    doc["methods"] = ["default", "bo", "bo_pso"]
    doc["repeats"] = 2
    doc["budget"].update(flights=8, default_flights=2)
    doc["validation"] = {"maps": 3}
    with open(path, "w", encoding="utf-8") as fh:
        yaml.safe_dump(doc, fh)


def chromium():
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    return None


def browse(browser, profile, url, extra):
    """Runs headless Chromium on `url` with a fresh profile folder under `profile`; returns
    (stdout, stderr). Headless Chromium now and then sits idle forever on a page it has loaded
    (no CPU used); such a run is killed after a guard time and run once more. The test has no
    speed requirement: the guard only keeps a hung browser from holding the suite."""
    for attempt in range(3):
        folder = tempfile.mkdtemp(prefix="chromium_", dir=profile)
        cmd = [browser, "--headless", "--no-sandbox", "--use-angle=swiftshader",
               "--enable-unsafe-swiftshader", "--enable-logging=stderr", "--v=0",
               "--force-device-scale-factor=1", "--hide-scrollbars", f"--user-data-dir={folder}",
               "--virtual-time-budget=15000", f"--window-size=1300,{WINDOW_HEIGHT}"] + extra + [url]
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
            return done.stdout, done.stderr
        except subprocess.TimeoutExpired:
            print(f"chromium sat idle on {url} for 300 s (attempt {attempt + 1}); running it again")
    check(False, f"chromium hung three times on {url}")


# The page is taken in one tall window. Headless Chromium (156, SwiftShader) never finishes a
# screenshot of a window taller than 8192 px, its largest surface; the report's panels end near
# 5 900 px.
WINDOW_HEIGHT = 8192


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


def check_tables(parsed, run, page):
    """The page's validation and parameter tables against tuning.md, the method names and
    colours, the Default's final value, and the evaluation table against the store."""
    md = markdown_tables(os.path.join(run, "tuning.md"))
    finals_md = table_starting(md, ["method", "repeats", "flights"])
    validation_md = table_starting(md, ["method", "points"])
    parameters_md = table_starting(md, ["parameter", "range", "Default"])
    validation = parsed.tables.get("qt-validation-table-run")
    check(validation is not None, "the page has the held-out validation table")
    check(validation == validation_md, "held-out validation table equals tuning.md's" +
          ("" if validation == validation_md else f": {validation} vs {validation_md}"))
    check(len(validation) == 4, "validation rows: Default, BO only, BO+PSO")
    parameters = parsed.tables.get("qt-parameter-table-run")
    check(parameters is not None, "the page has the tuned-parameter table")
    check(parameters == parameters_md, "tuned-parameter table equals tuning.md's" +
          ("" if parameters == parameters_md else f": {parameters} vs {parameters_md}"))
    check(len(parameters[0]) == 3 + 4, "parameter table: the defaults and four trials")
    # The numbers themselves: the defaults' mean on the held-out maps and the parameters.
    mean_md = float(validation_md[1][4].split("±")[0])
    mean_page = float(validation[1][4].split("±")[0])
    check(validation_md[1][0] == "Default" and mean_md == mean_page,
          f"the defaults' held-out mean f_l is tuning.md's ({mean_page} vs {mean_md})")
    # One name per method: tuning.md's labels are the page's (tables, data) and the shared ones.
    data = page_data(page)
    runs = data["runs"]
    labels_md = [r[0] for r in finals_md[1:]]
    labels_page = [m["label"] for m in runs["methods"]]
    shared = [quadtune_methods.label(k) for k in ("default", "bo", "bo_pso")]
    check(labels_md == labels_page == shared == ["Default", "BO only", "BO+PSO"],
          f"method names: tuning.md {labels_md}, page {labels_page}, shared {shared}")
    check([r[0] for r in validation[1:]] == labels_md,
          "the validation table names the methods as tuning.md does")
    check(all(m["colour"] == quadtune_methods.colour(m["key"]) for m in runs["methods"]),
          "the page's method colours are quadtune_methods' (the figures' colours)")
    check(len({m["colour"] for m in runs["methods"]}) == len(runs["methods"]),
          "one colour per method")
    # The Default's final value: the mean f_l of its flights in both.
    final_md = float(finals_md[1][3].split("±")[0])
    default_finals = [v["value"] for f in runs["finals"] if f["method"] == "default"
                      for v in f["values"]]
    final_page = statistics.fmean(default_finals)
    check(abs(final_page - final_md) <= 0.005 + 1e-9,
          f"the Default's final value is tuning.md's: {final_page:.3f} vs {final_md}")
    con = sqlite3.connect(os.path.join(run, "results.sqlite"))
    default_flights = [v for (v,) in con.execute(
        "SELECT value FROM evaluation WHERE kind = 'long' AND method = 'default'")]
    check(abs(final_page - statistics.fmean(default_flights)) < 1e-9,
          "the Default's final value is the mean f_l of its flights")
    # The evaluation table: tuning flights by default, counted with their states.
    n_long, n_ok = con.execute("SELECT COUNT(*), SUM(state = 'ok') FROM evaluation "
                               "WHERE kind = 'long'").fetchone()
    states = {s for (s,) in con.execute("SELECT DISTINCT state FROM evaluation WHERE kind = 'long'")}
    con.close()
    table = parsed.tables.get("qt-evaluations")
    check(table is not None and parsed.attrs["qt-evaluations"].get("data-rows") == str(n_long),
          f"the evaluation table lists the {n_long} tuning flights")
    check(f"{n_long} of " in parsed.texts.get("qt-eval-count", "") and
          f"{n_ok} of them ok" in parsed.texts.get("qt-eval-count", ""),
          f"the evaluation count says {n_ok} ok: {parsed.texts.get('qt-eval-count')!r}")
    state_col = table[0].index("state")
    check({r[state_col] for r in table[1:]} == states,
          f"the evaluation table shows the stored states {sorted(states)}")
    # Importance: Sobol' indices of f_l over the run's parameters, in [0, 1] up to estimation.
    imp = [i for i in runs["importance"] if i["objective"].startswith("f_l")]
    check(len(imp) == 1 and len(imp[0]["parameters"]) == 6 and
          all(-0.1 <= v <= 1.1 for v in imp[0]["total"]) and "contour" in imp[0],
          "the f_l importance has a Sobol' index per parameter and a contour")


def main():
    quadtune, experiment = sys.argv[1], sys.argv[2]
    browser = chromium()
    if browser is None:
        print("SKIP: no chromium on PATH (scripts/setup.sh installs Debian's chromium)")
        return SKIP
    from PIL import Image  # Debian: python3-pil

    work = tempfile.mkdtemp(prefix="quadtune_report_test_")
    run = os.path.join(work, "run")
    profiles = os.path.join(work, "profiles")
    os.makedirs(profiles)
    small = os.path.join(work, "small.yaml")
    small_experiment(experiment, small)
    # The run ends by drawing its figures, tuning.md and the report; `report` draws it again with
    # one stored flight to replay.
    subprocess.run([quadtune, "--log-level", "warn", "run", small, "--out", run], check=True)
    check(os.path.isfile(os.path.join(run, "tuning.md")), "the run wrote tuning.md")
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
        dom, err = browse(browser, profiles, f"{url}#t={t:.3f}",
                          ["--dump-dom"])
        parsed = Page()
        parsed.feed(dom)
        body = parsed.attrs.get("body", {})
        check(body.get("data-ready") == "1", f"the page's script ran to the end (t = {t:.2f})")
        if t == times[0]:
            check_tables(parsed, run, page)
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
    check(all(y + h <= WINDOW_HEIGHT for _, y, _, h in boxes.values()),
          f"every panel lies inside the {WINDOW_HEIGHT} px window")

    shots = []
    for t in times:
        png = os.path.join(work, f"shot_{t:.2f}.png")
        _, err = browse(browser, profiles, f"{url}#t={t:.3f}",
                        [f"--screenshot={png}"])
        check(os.path.isfile(png), f"screenshot at t = {t:.2f} s")
        check(not console_errors(err), "no console error while rendering")
        shots.append(Image.open(png).convert("RGB"))
    # Axes, grid lines and labels are grey; data (lines, markers, bars, obstacles) is coloured.
    # An empty chart or a blank canvas has no coloured pixel.
    for name in ("qt-validation", "qt-convergence", "qt-finals", "qt-ecdf", "qt-importance",
                 "qt-contour", "qt-slices", "qt-parcoords", "qt-scene"):
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
