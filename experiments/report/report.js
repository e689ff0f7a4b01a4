// The report page's code (an ES module inlined by quadtune_report.py): charts with plotly.js
// (global Plotly), the 3-D flight replay with three.js. Test hook: window.qtReplay
// (seek(t), position(), duration); URL fragment #t=SECONDS&flight=INDEX seeks on load.
import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";

const data = JSON.parse(document.getElementById("qt-data").textContent);
const plotConfig = { responsive: true, displaylogo: false };
const fragment = new URLSearchParams(window.location.hash.slice(1));
// One naming and one colour per method, from the data (experiments/plot/quadtune_methods.py,
// shared with the PNG figures and tuning.md).
const methodInfo = {};
for (const m of (data.runs && data.runs.methods) || []) methodInfo[m.key] = m;
const label = (method) => (methodInfo[method] ? methodInfo[method].label : method);
const colour = (method) => (methodInfo[method] ? methodInfo[method].colour : "#444444");
const several = () => data.runs.stores.length > 1;
// Stores of a study: one line style each (the colour stays the method's).
const dashOf = (store) => ["solid", "dash", "dot", "dashdot", "longdash"][
    Math.max(0, data.runs.stores.indexOf(store)) % 5];
const seriesName = (store, method) => (several() ? `${store} · ${label(method)}` : label(method));

function logScaleFits(values) {
  const pos = values.filter((v) => v > 0);
  return pos.length === values.length && Math.max(...pos) / Math.min(...pos) > 50;
}

function withAlpha(hex, alpha) {
  const n = parseInt(hex.slice(1), 16);
  return `rgba(${(n >> 16) & 255},${(n >> 8) & 255},${n & 255},${alpha})`;
}

/// A value axis: logarithmic with ticks at 1, 2 and 5 per decade when the values span more
/// than a factor 50, linear otherwise.
function valueAxis(values) {
  if (!logScaleFits(values)) return { type: "linear" };
  const lo = Math.floor(Math.log10(Math.min(...values))), hi = Math.ceil(Math.log10(Math.max(...values)));
  const tickvals = [];
  for (let e = lo; e <= hi; e++) for (const m of [1, 2, 5]) tickvals.push(m * 10 ** e);
  return { type: "log", tickvals, ticktext: tickvals.map((v) => String(+v.toPrecision(3))) };
}

function fmt(v, digits = 2) { return v === null || v === undefined ? "–" : (+v).toFixed(digits); }

/// A table of strings (header, rows) into `table`; the first cell of each row gets the colour
/// dot of `methods[k]` when given.
// One store's table (id `${prefix}-${store}`) appended to `box`, under the store's name when the
// page shows several stores; returns the table.
function storeTable(box, prefix, store, header, cells, methods) {
  const wrap = document.createElement("div");
  if (several()) {
    const h = document.createElement("h3");
    h.textContent = store;
    wrap.appendChild(h);
  }
  const table = document.createElement("table");
  table.className = "data";
  table.id = `${prefix}-${store}`;
  table.dataset.store = store;
  fillTable(table, header, cells, methods);
  wrap.appendChild(table);
  box.appendChild(wrap);
  return table;
}

function fillTable(table, header, rows, methods) {
  table.innerHTML = "";
  const head = table.createTHead().insertRow();
  for (const h of header) { const th = document.createElement("th"); th.textContent = h; head.appendChild(th); }
  const body = table.createTBody();
  rows.forEach((row, k) => {
    const tr = body.insertRow();
    row.forEach((cell, i) => {
      const td = tr.insertCell();
      if (i === 0 && methods && methods[k]) {
        const dot = document.createElement("span");
        dot.className = "method-dot";
        dot.style.background = colour(methods[k]);
        td.appendChild(dot);
      }
      td.appendChild(document.createTextNode(cell));
    });
  });
}

// ---------------------------------------------------------------------------------------------
// Charts

function drawValidation(runs) {
  const box = document.getElementById("qt-validation-tables");
  const traces = [];
  const names = [];
  for (const v of runs.validation) {
    const ranked = [...v.rows].sort((a, b) => b.mean - a.mean);  // plotly draws the first at the bottom
    for (const r of ranked) {
      const name = seriesName(v.store, r.method) +
          (r.method === "default" || r.p_default === null ? "" : ` (p = ${fmt(r.p_default, 3)})`);
      names.push(name);
      const own = v.flights.filter((f) => f.method === r.method);
      traces.push({
        type: "scatter", mode: "markers", x: own.map((f) => f.value), y: own.map(() => name),
        marker: { size: 6, color: withAlpha(colour(r.method), 0.45) }, showlegend: false,
        text: own.map((f) => `repeat ${f.repeat}, map ${f.map}, ${f.state}`), hoverinfo: "x+text",
        yaxis: "y", xaxis: "x",
      });
      traces.push({
        type: "scatter", mode: "markers", name, x: [r.mean], y: [name], showlegend: false,
        marker: { symbol: "diamond", size: 13, color: colour(r.method), line: { color: "#222", width: 1 } },
        error_x: { type: "data", array: [r.ci === null ? 0 : r.ci], thickness: 2.5, width: 8,
                   color: colour(r.method) },
        text: [`mean ${fmt(r.mean)} ± ${fmt(r.ci)} (95% CI), ${r.flights} flights` +
               (r.method === "default" ? "" : `, Δ vs Default ${fmt(r.diff_default)}, p = ${fmt(r.p_default, 3)}`)],
        hoverinfo: "text",
      });
      traces.push({
        type: "bar", orientation: "h", x: [r.collision_free / r.flights], y: [name], xaxis: "x2", yaxis: "y",
        marker: { color: colour(r.method) }, showlegend: false,
        text: [`${r.collision_free}/${r.flights}`],
        textposition: "inside", insidetextanchor: "start", hoverinfo: "text",
      });
    }
    storeTable(box, "qt-validation-table", v.store, v.header, v.cells, v.rows.map((r) => r.method));
  }
  document.getElementById("qt-validation-caption").textContent = runs.validation.map(
      (v) => `${several() ? v.store + ": " : ""}${v.maps} held-out maps`).join("; ") + ".";
  const height = Math.max(220, 120 + 42 * names.length);
  document.getElementById("qt-validation").style.height = `${height}px`;
  const all = runs.validation.flatMap((v) => v.flights.map((f) => f.value));
  Plotly.newPlot("qt-validation", traces, {
    margin: { t: 30, r: 10, l: 160 }, showlegend: false,
    xaxis: { domain: [0, 0.68], title: { text: "f_l on held-out maps (mean, 95% CI; dots: flights)" },
             ...valueAxis(all) },
    xaxis2: { domain: [0.74, 1], range: [0, 1], title: { text: "collision-free share" } },
    yaxis: { automargin: true, categoryorder: "array", categoryarray: names },
  }, plotConfig);
}

function drawParameters(runs) {
  const box = document.getElementById("qt-parameter-tables");
  document.getElementById("qt-parameters-caption").textContent = runs.parameters_caption;
  for (const t of runs.parameter_tables) {
    const table = storeTable(box, "qt-parameter-table", t.store, t.header, t.cells);
    // The trial columns' heads take their method's colour.
    const heads = table.tHead.rows[0].cells;
    t.points.forEach((p, k) => { heads[3 + k].style.color = colour(p.method); });
    heads[2].style.color = colour("default");
  }
}

function drawConvergence(runs) {
  const traces = [];
  const all = [];
  for (const s of runs.series) {
    const c = colour(s.method);
    const name = seriesName(s.store, s.method);
    all.push(...s.lo, ...s.hi);
    traces.push({ x: s.x.concat([...s.x].reverse()), y: s.hi.concat([...s.lo].reverse()),
                  fill: "toself", fillcolor: withAlpha(c, 0.15), line: { width: 0 }, mode: "lines",
                  hoverinfo: "skip", showlegend: false, legendgroup: name, type: "scatter" });
    traces.push({ x: s.x, y: s.median, name: `${name} (${s.trials} repeat${s.trials > 1 ? "s" : ""})`,
                  legendgroup: name, line: { color: c, width: 2.5, shape: "hv", dash: dashOf(s.store) },
                  mode: "lines+markers", type: "scatter" });
  }
  Plotly.newPlot("qt-convergence", traces, {
    margin: { t: 40, r: 10 }, legend: { orientation: "h", x: 0, y: 1.02, yanchor: "bottom" },
    xaxis: { title: { text: "flights" }, tick0: 1,
             dtick: Math.max(1, Math.ceil(Math.max(...runs.series.map((s) => s.x.length)) / 12)) },
    yaxis: { title: { text: "best f_l so far" }, ...valueAxis(all) },
  }, plotConfig);
}

function drawFinals(runs) {
  document.getElementById("qt-final-definition").textContent = runs.final_value;
  const median = (v) => { const s = [...v].sort((a, b) => a - b); const m = (s.length - 1) / 2;
                          return (s[Math.floor(m)] + s[Math.ceil(m)]) / 2; };
  const ranked = runs.finals.map((f) => ({ ...f, vals: f.values.map((v) => v.value) }))
                            .map((f) => ({ ...f, med: median(f.vals), label: seriesName(f.store, f.method) }))
                            .sort((a, b) => b.med - a.med);  // plotly draws the first at the bottom
  const names = ranked.map((f) => f.label);
  const traces = [{
    type: "scatter", mode: "markers", name: "median", y: names, x: ranked.map((f) => f.med),
    marker: { symbol: "diamond", size: 13, color: ranked.map((f) => colour(f.method)) },
    error_x: { type: "data", symmetric: false, array: ranked.map((f) => Math.max(...f.vals) - f.med),
               arrayminus: ranked.map((f) => f.med - Math.min(...f.vals)), thickness: 2, width: 6,
               color: "#444" },
  }, {
    type: "scatter", mode: "markers", name: "repeats", y: ranked.flatMap((f) => f.vals.map(() => f.label)),
    x: ranked.flatMap((f) => f.vals), marker: { size: 7, color: "rgba(0,0,0,0.55)" },
    text: ranked.flatMap((f) => f.values.map((v) => `repeat ${v.repeat}`)),
  }];
  const all = ranked.flatMap((f) => f.vals);
  const height = Math.max(200, 110 + 45 * names.length);
  document.getElementById("qt-finals").style.height = `${height}px`;
  Plotly.newPlot("qt-finals", traces, {
    margin: { t: 40, r: 10, l: 160 }, legend: { orientation: "h", x: 0, y: 1.02, yanchor: "bottom" },
    xaxis: { title: { text: "final f_l" }, ...valueAxis(all) },
    yaxis: { automargin: true },
  }, plotConfig);
}

function evaluationRows(runs) {
  const fields = runs.evaluations.fields;
  return runs.evaluations.rows.map((r) => Object.fromEntries(fields.map((f, i) => [f, r[i]])));
}

function drawEcdf(runs, kind) {
  const rows = evaluationRows(runs).filter((r) => (kind === "validation" ? r.kind === "validation"
                                                                          : r.kind === "long" || r.kind === "race"));
  const groups = {};
  for (const r of rows) (groups[`${r.store}\u0000${r.method}`] = groups[`${r.store}\u0000${r.method}`] || []).push(r);
  const traces = [];
  for (const method of runs.methods.map((m) => m.key)) {
    for (const store of runs.stores) {
      const rs = groups[`${store}\u0000${method}`];
      if (!rs) continue;
      const v = rs.map((r) => r.value).sort((a, b) => a - b);
      traces.push({ type: "scatter", mode: "lines", name: `${seriesName(store, method)} (${v.length})`,
                    x: v, y: v.map((_, k) => (k + 1) / v.length), line: { shape: "hv", width: 2.2,
                    color: colour(method), dash: dashOf(store) } });
    }
  }
  const all = rows.map((r) => r.value);
  Plotly.react("qt-ecdf", traces, {
    margin: { t: 40, r: 10 }, legend: { orientation: "h", x: 0, y: 1.02, yanchor: "bottom" },
    xaxis: { title: { text: "f_l" }, ...valueAxis(all) },
    yaxis: { title: { text: "share of flights with f_l ≤ x" }, range: [0, 1.02] },
  }, plotConfig);
}

function drawImportance(runs) {
  // One panel per objective (and store), side by side: S_T as bars, S_1 as diamonds.
  const traces = [];
  const captions = [];
  const layout = { margin: { t: 60, r: 10 }, legend: { orientation: "h", x: 0, y: 1.1, yanchor: "bottom" },
                   annotations: [] };
  const n = runs.importance.length;
  const gap = 0.06;
  runs.importance.forEach((imp, k) => {
    const key = several() ? `${imp.store} · ${imp.objective}` : imp.objective;
    const ax = k === 0 ? "" : String(k + 1);
    const width = (1 - gap * (n - 1)) / n;
    layout[`xaxis${ax}`] = { domain: [k * (width + gap), k * (width + gap) + width], range: [0, 1],
                             title: { text: "Sobol' index" }, anchor: `y${ax}` };
    layout[`yaxis${ax}`] = { automargin: true, autorange: "reversed", anchor: `x${ax}` };
    layout.annotations.push({ text: `${key}: n = ${imp.n}, R² = ${fmt(imp.loo_r2)}`, showarrow: false,
                              xref: "paper", yref: "paper", x: k * (width + gap), xanchor: "left",
                              y: 1.0, yanchor: "bottom", font: { size: 12 } });
    traces.push({
      type: "bar", orientation: "h", name: "total S_T", y: imp.parameters, x: imp.total,
      xaxis: `x${ax}`, yaxis: `y${ax}`, marker: { color: "#555555" }, showlegend: k === 0,
      text: imp.parameters.map((p, i) => `S_T = ${fmt(imp.total[i])}, S_1 = ${fmt(imp.first[i])}`),
      hoverinfo: "text+y", textposition: "none",
    });
    traces.push({
      type: "scatter", mode: "markers", name: "first order S_1", y: imp.parameters,
      x: imp.first.map((v) => Math.max(0, v)), xaxis: `x${ax}`, yaxis: `y${ax}`,
      marker: { symbol: "diamond", size: 11, color: "#ff7f0e", line: { color: "#222", width: 1 } },
      showlegend: k === 0, hoverinfo: "skip",
    });
    captions.push(`${key}: n = ${imp.n}, R² = ${fmt(imp.loo_r2)}`);
  });
  document.getElementById("qt-importance-caption").textContent =
      n ? captions.join("; ") + "."
        : "Too few evaluations for an importance estimate (at least 12 that finished).";
  if (!n) { document.getElementById("qt-importance").style.display = "none"; return; }
  Plotly.newPlot("qt-importance", traces, layout, plotConfig);
}

function drawContour(runs) {
  const imp = runs.importance.find((i) => i.contour);
  const div = document.getElementById("qt-contour");
  if (!imp) {
    div.style.display = "none";
    document.getElementById("qt-contour-caption").textContent =
        "No surrogate of f_l (too few flights that finished): no contour.";
    return;
  }
  const c = imp.contour;
  const traces = [{
    type: "contour", x: c.xs, y: c.ys, z: c.z, colorscale: "Viridis", reversescale: true,
    contours: { coloring: "heatmap", showlabels: true }, colorbar: { title: { text: "f_l" } },
    hovertemplate: `${c.x} = %{x:.3g}<br>${c.y} = %{y:.3g}<br>f_l ≈ %{z:.3g}<extra></extra>`,
  }];
  for (const method of runs.methods.map((m) => m.key)) {
    const idx = c.points.method.map((m, k) => (m === method ? k : -1)).filter((k) => k >= 0);
    if (!idx.length) continue;
    traces.push({ type: "scatter", mode: "markers", name: label(method),
                  x: idx.map((k) => c.points.x[k]), y: idx.map((k) => c.points.y[k]),
                  text: idx.map((k) => `f_l = ${c.points.value[k].toPrecision(4)}`),
                  marker: { color: colour(method), size: 7, line: { color: "#fff", width: 1 } } });
  }
  Plotly.newPlot(div, traces, {
    margin: { t: 40, r: 10 }, legend: { orientation: "h", x: 0, y: 1.02, yanchor: "bottom" },
    xaxis: { title: { text: c.x }, type: c.log_x ? "log" : "linear" },
    yaxis: { title: { text: c.y }, type: c.log_y ? "log" : "linear" },
  }, plotConfig);
}

const EVALUATION_LIMIT = 500;

function setUpEvaluations(runs) {
  const rows = evaluationRows(runs);
  const box = document.getElementById("qt-eval-filters");
  const filters = {};
  const keys = ["kind", "method", "state", "repeat"];
  if (several()) keys.unshift("store");
  for (const key of keys) {
    const values = [...new Set(rows.map((r) => r[key]))].filter((v) => v !== null && v !== undefined);
    values.sort((a, b) => (typeof a === "number" ? a - b : String(a).localeCompare(String(b))));
    const lab = document.createElement("label");
    lab.textContent = `${key} `;
    const select = document.createElement("select");
    select.id = `qt-eval-${key}`;
    select.add(new Option("all", ""));
    for (const v of values) select.add(new Option(key === "method" ? label(v) : String(v), String(v)));
    if (key === "kind" && values.includes("long")) select.value = "long";
    select.addEventListener("change", render);
    lab.appendChild(select);
    box.appendChild(lab);
    filters[key] = select;
  }
  const table = document.getElementById("qt-evaluations");
  function render() {
    const shown = rows.filter((r) => keys.every((k) => filters[k].value === "" || String(r[k]) === filters[k].value));
    document.getElementById("qt-eval-count").textContent =
        `${shown.length} of ${rows.length} evaluations match` +
        (shown.length > EVALUATION_LIMIT ? ` (the first ${EVALUATION_LIMIT} shown)` : "") +
        `; ${shown.filter((r) => r.state === "ok").length} of them ok.`;
    const header = (several() ? ["store"] : []).concat(["id", "kind", "method", "repeat", "iteration", "value", "state", "reason"]);
    const cells = shown.slice(0, EVALUATION_LIMIT).map((r) => (several() ? [r.store] : []).concat([
      String(r.id), r.kind, label(r.method), r.repeat === null ? "–" : String(r.repeat), String(r.iteration),
      (+r.value).toPrecision(5), r.state,
      (r.message || "") + (r.n_c ? `${r.message ? ", " : ""}n_c = ${r.n_c}` : "")]));
    fillTable(table, header, cells);
    for (const tr of table.tBodies[0].rows) tr.cells[tr.cells.length - 1].className = "reason";
    table.dataset.rows = String(shown.length);
  }
  render();
}

function drawSlices(runs) {
  const box = document.getElementById("qt-slices");
  const values = runs.flights.map((f) => f.value);
  const log = logScaleFits(values);
  for (const p of runs.parameters) {
    const div = document.createElement("div");
    div.className = "chart";
    box.appendChild(div);
    const bySeries = {};
    for (const f of runs.flights) {
      if (f.params[p] === undefined) continue;
      (bySeries[f.series] = bySeries[f.series] || []).push(f);
    }
    const traces = Object.entries(bySeries).map(([series, fs]) => ({
      type: "scatter", mode: "markers", name: several() ? series.replace(fs[0].method, label(fs[0].method)) : label(fs[0].method),
      x: fs.map((f) => f.params[p]),
      y: fs.map((f) => f.value), marker: { color: colour(fs[0].method), size: 7, opacity: 0.8 },
      text: fs.map((f) => `evaluation ${f.id}`), showlegend: p === runs.parameters[0],
    }));
    Plotly.newPlot(div, traces, {
      margin: { t: 30, r: 8, b: 42, l: 55 }, xaxis: { title: { text: p } },
      yaxis: { title: { text: "f_l" }, type: log ? "log" : "linear" },
      legend: { orientation: "h", x: 0, y: 1.02, yanchor: "bottom", font: { size: 10 } },
    }, plotConfig);
  }
}

function drawParcoords(runs) {
  const flights = runs.flights.filter((f) => f.value > 0 &&
                                             runs.parameters.every((p) => f.params[p] !== undefined));
  if (flights.length === 0) return;
  const series = [...new Set(flights.map((f) => f.series))];
  const logv = flights.map((f) => Math.log10(f.value));
  const dims = runs.parameters.map((p) => ({ label: p, values: flights.map((f) => f.params[p]) }));
  if (series.length > 1) {
    dims.unshift({ label: "method", values: flights.map((f) => series.indexOf(f.series)),
                   tickvals: series.map((_, i) => i),
                   ticktext: series.map((s) => { const f = flights.find((x) => x.series === s);
                                                 return several() ? s.replace(f.method, label(f.method)) : label(f.method); }) });
  }
  dims.push({ label: "log10 f_l", values: logv });
  Plotly.newPlot("qt-parcoords", [{
    type: "parcoords", dimensions: dims,
    line: { color: logv, colorscale: "Viridis", reversescale: true, showscale: true,
            colorbar: { title: { text: "log10 f_l" } } },
  }], { margin: { t: 40, r: 60, l: 70, b: 20 } }, plotConfig);
}

// ---------------------------------------------------------------------------------------------
// 3-D replay (world frame: z up, metres)

class Replay {
  constructor(container) {
    this.container = container;
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(window.devicePixelRatio);
    this.renderer.setSize(container.clientWidth, container.clientHeight);
    container.appendChild(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0xeef2f6);
    this.camera = new THREE.PerspectiveCamera(45, container.clientWidth / container.clientHeight, 0.05, 500);
    this.camera.up.set(0, 0, 1);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener("change", () => this.render());
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x667788, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(5, -8, 12);
    this.scene.add(sun);
    this.world = new THREE.Group();
    this.scene.add(this.world);
    this.drone = this.makeDrone();
    this.scene.add(this.drone);
    this.time = 0;
    this.playing = false;
    this.speed = 1;
    window.addEventListener("resize", () => this.resize());
  }

  makeDrone() {
    const g = new THREE.Group();
    const body = new THREE.Mesh(new THREE.BoxGeometry(0.22, 0.22, 0.07),
                                new THREE.MeshStandardMaterial({ color: 0x222222 }));
    g.add(body);
    const nose = new THREE.Mesh(new THREE.BoxGeometry(0.12, 0.04, 0.04),
                                new THREE.MeshStandardMaterial({ color: 0xd62728 }));
    nose.position.set(0.14, 0, 0);
    g.add(nose);
    const rotorMat = new THREE.MeshStandardMaterial({ color: 0x2ca02c, transparent: true, opacity: 0.8 });
    for (const [x, y] of [[0.17, 0.17], [0.17, -0.17], [-0.17, 0.17], [-0.17, -0.17]]) {
      const rotor = new THREE.Mesh(new THREE.CylinderGeometry(0.1, 0.1, 0.015, 24), rotorMat);
      rotor.rotation.x = Math.PI / 2;
      rotor.position.set(x, y, 0.04);
      g.add(rotor);
    }
    return g;
  }

  load(flight) {
    this.flight = flight;
    this.world.clear();
    const o = flight.obstacles;
    const wood = new THREE.MeshStandardMaterial({ color: 0x8a6d3b, roughness: 0.9 });
    for (const c of o.cylinders || []) {
      const h = c.z_max - c.z_min;
      const m = new THREE.Mesh(new THREE.CylinderGeometry(c.radius, c.radius, h, 20), wood);
      m.rotation.x = Math.PI / 2;  // three's cylinder axis is y; the world's is z
      m.position.set(c.x, c.y, c.z_min + h / 2);
      this.world.add(m);
    }
    const ringMat = new THREE.MeshStandardMaterial({ color: 0x9467bd });
    for (const r of o.rings || []) {
      const m = new THREE.Mesh(new THREE.TorusGeometry(r.radius, r.thickness / 2, 16, 48), ringMat);
      // The torus axis is z; turn it to the ring's horizontal axis at heading `yaw`.
      m.rotation.set(0, Math.PI / 2, r.yaw, "ZYX");
      m.position.set(r.x, r.y, r.z);
      this.world.add(m);
    }
    const pts = flight.p.map((p) => new THREE.Vector3(p[0], p[1], p[2]));
    const box = new THREE.Box3().setFromPoints(pts);
    for (const c of o.cylinders || []) box.expandByPoint(new THREE.Vector3(c.x, c.y, 0));
    const size = box.getSize(new THREE.Vector3());
    const centre = box.getCenter(new THREE.Vector3());
    const ground = new THREE.Mesh(new THREE.PlaneGeometry(size.x + 4, size.y + 4),
                                  new THREE.MeshStandardMaterial({ color: 0xdde5d0 }));
    ground.position.set(centre.x, centre.y, 0);
    this.world.add(ground);
    const grid = new THREE.GridHelper(Math.ceil(Math.max(size.x, size.y) + 4), Math.ceil(Math.max(size.x, size.y) + 4),
                                      0xaaaaaa, 0xcccccc);
    grid.rotation.x = Math.PI / 2;
    grid.position.set(centre.x, centre.y, 0.005);
    this.world.add(grid);
    // The flown path: full (faint) and up to the current time (solid).
    this.world.add(new THREE.Line(new THREE.BufferGeometry().setFromPoints(pts),
                                  new THREE.LineBasicMaterial({ color: 0x9ec5e8 })));
    this.path = new THREE.Line(new THREE.BufferGeometry().setFromPoints(pts),
                               new THREE.LineBasicMaterial({ color: 0x1f77b4 }));
    this.world.add(this.path);
    // Plans: one line each, shown from their time on.
    this.plans = flight.plans.map((pl) => {
      const line = new THREE.Line(
          new THREE.BufferGeometry().setFromPoints(pl.p.map((p) => new THREE.Vector3(p[0], p[1], p[2]))),
          new THREE.LineBasicMaterial({ color: 0xbbbbbb }));
      line.visible = false;
      this.world.add(line);
      return { t0: pl.t0, line };
    });
    // The plan in use: beads along it (WebGL lines are one pixel wide and hide under the path).
    const longest = Math.max(1, ...flight.plans.map((pl) => pl.p.length));
    this.beads = new THREE.InstancedMesh(new THREE.SphereGeometry(0.035, 8, 6),
                                         new THREE.MeshBasicMaterial({ color: 0xff7f0e }), longest);
    this.beads.count = 0;
    this.beadsOf = -1;
    this.world.add(this.beads);
    const start = flight.summary.start, goal = flight.summary.goal;
    for (const [p, col] of [[start, 0x2ca02c], [goal, 0xd62728]]) {
      if (!p) continue;
      const m = new THREE.Mesh(new THREE.SphereGeometry(0.12, 16, 12),
                               new THREE.MeshStandardMaterial({ color: col }));
      m.position.set(p[0], p[1], p[2]);
      this.world.add(m);
    }
    this.duration = flight.t.length ? flight.t[flight.t.length - 1] : 0;
    const reach = Math.max(size.x, size.y, 4);
    this.camera.position.set(centre.x - 0.15 * reach, centre.y - 1.1 * reach, centre.z + 0.8 * reach);
    this.controls.target.copy(centre);
    this.controls.update();
    this.seek(0);
  }

  /// Drone position and yaw at time t (linear interpolation of the state log).
  stateAt(t) {
    const ts = this.flight.t;
    if (ts.length === 0) return { p: [0, 0, 0], yaw: 0, i: 0 };
    let lo = 0, hi = ts.length - 1;
    if (t <= ts[0]) return { p: this.flight.p[0], yaw: this.flight.yaw[0], i: 0 };
    if (t >= ts[hi]) return { p: this.flight.p[hi], yaw: this.flight.yaw[hi], i: hi };
    while (hi - lo > 1) { const mid = (lo + hi) >> 1; if (ts[mid] <= t) lo = mid; else hi = mid; }
    const a = (t - ts[lo]) / (ts[hi] - ts[lo]);
    const p0 = this.flight.p[lo], p1 = this.flight.p[hi];
    return { p: [0, 1, 2].map((k) => p0[k] + a * (p1[k] - p0[k])),
             yaw: this.flight.yaw[lo] + a * (this.flight.yaw[hi] - this.flight.yaw[lo]), i: lo };
  }

  seek(t) {
    this.time = Math.min(Math.max(t, 0), this.duration);
    const s = this.stateAt(this.time);
    this.drone.position.set(s.p[0], s.p[1], s.p[2]);
    this.drone.rotation.set(0, 0, s.yaw);
    this.path.geometry.setDrawRange(0, s.i + 1);
    let current = -1;
    this.plans.forEach((pl, k) => { if (pl.t0 <= this.time) current = k; });
    this.plans.forEach((pl, k) => {
      pl.line.visible = k <= current && k >= current - 3;
      pl.line.material = k === current ? Replay.currentPlan : Replay.oldPlan;
    });
    if (current !== this.beadsOf) {
      const pts = current >= 0 ? this.flight.plans[current].p : [];
      const m = new THREE.Matrix4();
      pts.forEach((p, k) => this.beads.setMatrixAt(k, m.makeTranslation(p[0], p[1], p[2])));
      this.beads.count = pts.length;
      this.beads.instanceMatrix.needsUpdate = true;
      this.beadsOf = current;
    }
    document.getElementById("qt-scrub").value = String(this.time);
    document.getElementById("qt-time").textContent =
        `t = ${this.time.toFixed(2)} s of ${this.duration.toFixed(2)} s` +
        (current >= 0 ? `, plan ${current + 1} of ${this.plans.length} (from t = ${this.plans[current].t0.toFixed(2)} s)` : "");
    const pos = document.getElementById("qt-drone-pos");
    pos.dataset.t = this.time.toFixed(3);
    [pos.dataset.x, pos.dataset.y, pos.dataset.z] = s.p.map((v) => v.toFixed(3));
    pos.textContent = `drone at (${s.p.map((v) => v.toFixed(2)).join(", ")}) m`;
    this.render();
  }

  position() { return this.drone.position.toArray(); }

  render() { this.renderer.render(this.scene, this.camera); }

  resize() {
    const w = this.container.clientWidth, h = this.container.clientHeight;
    this.renderer.setSize(w, h);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.render();
  }

  play() {
    if (this.time >= this.duration) this.seek(0);
    this.playing = true;
    let last = performance.now();
    const step = (now) => {
      if (!this.playing) return;
      this.seek(this.time + this.speed * (now - last) / 1000);
      last = now;
      if (this.time >= this.duration) { this.pause(); return; }
      requestAnimationFrame(step);
    };
    requestAnimationFrame(step);
    document.getElementById("qt-play").textContent = "Pause";
  }

  pause() {
    this.playing = false;
    document.getElementById("qt-play").textContent = "Play";
  }
}
Replay.currentPlan = new THREE.LineBasicMaterial({ color: 0xff7f0e });
Replay.oldPlan = new THREE.LineBasicMaterial({ color: 0xbbbbbb });

function describe(flight) {
  const s = flight.summary;
  const rows = [["status", s.status + (s.message ? ` (${s.message})` : "")],
                ["flight time t_f", `${(+s.flight_time).toFixed(2)} s`],
                ["collisions n_c", s.collisions], ["emergency stops n_e", s.emergency_stops],
                ["plans", `${s.plans} (failed ${s.failed_plans})`],
                ["mean speed", `${(+s.mean_speed).toFixed(2)} m/s`]];
  if (s.stored) {
    rows.unshift(["stored flight", `${label(s.stored.method)}, evaluation ${s.stored.evaluation}, ` +
                                   `f_l = ${(+s.stored.value).toPrecision(5)}`]);
    rows.push(["parameters", Object.entries(s.stored.params).map(([k, v]) => `${k} = ${(+v).toPrecision(4)}`).join(", ")]);
    rows.push(["seeds", `map ${s.stored.map_seed}, flight ${s.stored.flight_seed}`]);
  }
  const table = document.getElementById("qt-flight-summary");
  table.innerHTML = "";
  for (const [k, v] of rows) {
    const tr = table.insertRow();
    tr.insertCell().textContent = k;
    tr.insertCell().textContent = String(v);
  }
}

function setUpReplay(flights) {
  const replay = new Replay(document.getElementById("qt-scene"));
  const select = document.getElementById("qt-flight");
  flights.forEach((f, k) => {
    const name = f.summary.stored ? `${f.name}: ${label(f.summary.stored.method)}` : f.name;
    select.add(new Option(name, String(k)));
  });
  const scrub = document.getElementById("qt-scrub");
  const choose = (k) => {
    replay.pause();
    replay.load(flights[k]);
    scrub.max = String(replay.duration);
    describe(flights[k]);
  };
  select.addEventListener("change", () => choose(+select.value));
  scrub.addEventListener("input", () => { replay.pause(); replay.seek(+scrub.value); });
  document.getElementById("qt-play").addEventListener("click",
      () => (replay.playing ? replay.pause() : replay.play()));
  document.getElementById("qt-speed").addEventListener("change",
      (e) => { replay.speed = +e.target.value; });
  const first = Math.min(Math.max(+(fragment.get("flight") || 0), 0), flights.length - 1);
  select.value = String(first);
  choose(first);
  window.qtReplay = {
    seek: (t) => replay.seek(t), position: () => replay.position(),
    get duration() { return replay.duration; }, play: () => replay.play(), pause: () => replay.pause(),
  };
  if (fragment.has("t")) replay.seek(+fragment.get("t"));
}

// ---------------------------------------------------------------------------------------------

const runs = data.runs;
const subtitle = document.getElementById("qt-subtitle");
if (runs && runs.series.length > 0) {
  const flown = evaluationRows(runs).filter((r) => r.kind !== "short");
  const ok = flown.filter((f) => f.state === "ok").length;
  const kinds = ["long", "race", "validation"].map((k) => [k, flown.filter((r) => r.kind === k).length]);
  subtitle.textContent = `${data.kind} of ${[...new Set(runs.experiments)].join(", ")}: ` +
      `${runs.stores.length} store${runs.stores.length > 1 ? "s" : ""}, ${flown.length} flights ` +
      `(${kinds.filter(([, c]) => c).map(([k, c]) => `${c} ${{ long: "tuning", race: "racing", validation: "held-out" }[k]}`).join(", ")}), ` +
      `${ok} of them ok; ${runs.methods.map((m) => m.label).join(", ")}`;
  if (runs.validation.length) drawValidation(runs);
  else document.getElementById("qt-validation-section").style.display = "none";
  if (runs.parameter_tables.length) drawParameters(runs);
  else document.getElementById("qt-parameters-section").style.display = "none";
  drawConvergence(runs);
  drawFinals(runs);
  const ecdfKind = document.getElementById("qt-ecdf-kind");
  if (!runs.validation.length) ecdfKind.disabled = true;
  ecdfKind.addEventListener("change", () => drawEcdf(runs, ecdfKind.value));
  drawEcdf(runs, "tuning");
  drawImportance(runs);
  drawContour(runs);
  drawSlices(runs);
  drawParcoords(runs);
  setUpEvaluations(runs);
} else {
  document.getElementById("qt-run-sections").style.display = "none";
  subtitle.textContent = data.kind === "flight" ? "a single flight" : "no flights stored";
}
const note = document.getElementById("qt-replay-note");
if (data.replays.length > 0) {
  note.textContent = data.kind === "flight"
      ? "The flight of this directory. Drag to orbit, scroll to zoom."
      : "Stored flights flown again from the results store (each method's best first): the flown path, " +
        "the plan in use at each time (and the three before it), and the drone. Drag to orbit, scroll to zoom.";
  setUpReplay(data.replays);
} else {
  document.getElementById("qt-replay-section").style.display = "none";
}
// Test hook: where the charts and the 3-D view lie on the page (CSS pixels, page coordinates).
const boxes = {};
for (const id of ["qt-validation", "qt-convergence", "qt-finals", "qt-ecdf", "qt-importance", "qt-contour",
                  "qt-slices", "qt-parcoords", "qt-scene"]) {
  const r = document.getElementById(id).getBoundingClientRect();
  if (r.width > 0) boxes[id] = [r.left + window.scrollX, r.top + window.scrollY, r.width, r.height].map(Math.round);
}
document.body.dataset.boxes = JSON.stringify(boxes);
document.body.dataset.ready = "1";
