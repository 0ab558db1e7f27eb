// uavbus console (docs/web.md). Plain JavaScript, no library: every asset ships in the Python package.
// Data comes from the console's JSON API; every write is prepare -> the operator confirms -> confirm.
"use strict";

const CSRF = document.querySelector('meta[name="uavbus-csrf"]').content;
const state = { view: "fleet", info: null, fleet: null, catalogue: null, varLeaf: null, varData: null,
  plot: { series: new Map(), paused: false, since: 0 }, refPos: null };
const COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2"];

// ---- small helpers ---------------------------------------------------------------------------------
const shown = new Map();
function unchanged(key, data) {  // tables are rebuilt only when what they show changed (keeps focus, selection)
  const text = JSON.stringify(data);
  if (shown.get(key) === text) return true;
  shown.set(key, text);
  return false;
}
function $(sel) { return document.querySelector(sel); }
function el(tag, attrs, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (k === "class") e.className = v;
    else if (k.startsWith("data-")) e.setAttribute(k, v);
    else if (k === "onclick") e.addEventListener("click", v);
    else e[k] = v;
  }
  for (const c of children) e.append(c instanceof Node ? c : document.createTextNode(c === null || c === undefined ? "" : String(c)));
  return e;
}
function fmt(v, digits) {
  if (v === null || v === undefined) return "-";
  if (typeof v === "number") return Number.isInteger(v) ? String(v) : v.toFixed(digits === undefined ? 3 : digits);
  if (typeof v === "object") return JSON.stringify(v);
  return String(v);
}
function say(text, kind) {
  const m = $("#message");
  m.textContent = text;
  m.className = "message " + (kind || "");
}
async function get(path) {
  const r = await fetch(path, { credentials: "same-origin" });
  if (r.status === 401) throw new Error(await r.text());
  const body = await r.json();
  return body;
}
async function post(path, body) {
  const r = await fetch(path, { method: "POST", credentials: "same-origin",
    headers: { "Content-Type": "application/json", "X-Uavbus-Csrf": CSRF }, body: JSON.stringify(body) });
  return await r.json();
}

// ---- the confirm step: nothing is written before the operator confirms what it will do ---------------
let pendingConfirm = null;
async function act(body, after) {
  const p = await post("/api/prepare", body);
  if (p.error) { say(p.error, "error"); return; }
  pendingConfirm = { id: p.confirm, after };
  $("#confirm-what").textContent = p.what;
  $("#confirm").classList.remove("hidden");
  $("#confirm-yes").focus();
}
async function confirmYes() {
  const c = pendingConfirm;
  pendingConfirm = null;
  $("#confirm").classList.add("hidden");
  if (!c) return;
  say("sent; waiting for the answer…", "");
  const r = await post("/api/confirm", { confirm: c.id });
  if (r.error) say(r.reason ? `refused (${r.reason}): ${r.error}` : r.error, "error");
  else say(r.message || "done", r.temporary ? "warn" : "ok");
  if (c.after) c.after(r);
}
async function confirmNo() {
  const c = pendingConfirm;
  pendingConfirm = null;
  $("#confirm").classList.add("hidden");
  if (c) await post("/api/cancel", { confirm: c.id });
  say("cancelled: nothing was sent", "");
}

// ---- tabs ----------------------------------------------------------------------------------------------
function show(view) {
  state.view = view;
  for (const b of document.querySelectorAll("nav .tab")) b.classList.toggle("active", b.dataset.view === view);
  for (const s of document.querySelectorAll(".view")) s.classList.toggle("hidden", s.id !== "view-" + view);
  refresh();
}

// ---- fleet ---------------------------------------------------------------------------------------------
function localNE(p) {
  if (!p || p.error) return null;
  if (p.n !== undefined) return [p.n, p.e];
  if (p.lat !== undefined) {
    if (!state.refPos) state.refPos = [p.lat, p.lon];
    const R = 6371000, rad = Math.PI / 180;
    return [(p.lat - state.refPos[0]) * rad * R, (p.lon - state.refPos[1]) * rad * R * Math.cos(state.refPos[0] * rad)];
  }
  return null;
}

function drawMap(fleet, canvas) {
  const cv = $(canvas || "#map"), g = cv.getContext("2d"), W = cv.width, H = cv.height;
  g.clearRect(0, 0, W, H);
  const ents = fleet.entities;
  const placed = new Map();
  const pts = [[0, 0]];  // the frame's origin stays in view
  for (const e of ents) { const ne = localNE(e.position); if (ne) pts.push(ne); }
  // Fit the box around every position (equal scale north and east), with room for the labels.
  const nMin = Math.min(...pts.map(p => p[0])), nMax = Math.max(...pts.map(p => p[0]));
  const eMin = Math.min(...pts.map(p => p[1])), eMax = Math.max(...pts.map(p => p[1]));
  const spanN = Math.max(nMax - nMin, 50), spanE = Math.max(eMax - eMin, 50);
  const scale = Math.min((W - 160) / spanE, (H - 80) / spanN);
  const n0 = (nMin + nMax) / 2, e0 = (eMin + eMax) / 2;
  const X = e => W / 2 - 40 + (e - e0) * scale, Y = n => H / 2 - (n - n0) * scale;
  const cx = X(0), cy = Y(0);
  // grid: one line every power of ten metres that gives a few lines
  g.strokeStyle = "#eef0f4"; g.lineWidth = 1;
  const widest = Math.max(spanN, spanE);
  let step = Math.pow(10, Math.floor(Math.log10(widest)));
  if (widest / step < 4) step /= 2;
  for (let v = Math.floor((e0 - W / scale) / step) * step; v <= e0 + W / scale; v += step) {
    g.beginPath(); g.moveTo(X(v), 0); g.lineTo(X(v), H); g.stroke();
  }
  for (let v = Math.floor((n0 - H / scale) / step) * step; v <= n0 + H / scale; v += step) {
    g.beginPath(); g.moveTo(0, Y(v)); g.lineTo(W, Y(v)); g.stroke();
  }
  g.fillStyle = "#4a5468"; g.font = "12px system-ui, sans-serif";
  g.fillText(`grid ${step} m · north up · local frame (metres north and east of the origin +)`, 10, H - 10);
  g.strokeStyle = "#9aa3b2"; g.beginPath(); g.moveTo(cx - 6, cy); g.lineTo(cx + 6, cy); g.moveTo(cx, cy - 6); g.lineTo(cx, cy + 6); g.stroke();
  // entities without a position: on a ring, labelled so
  let k = 0;
  const unplaced = ents.filter(e => !localNE(e.position));
  for (const e of ents) {
    const ne = localNE(e.position);
    if (ne) placed.set(e.name, [X(ne[1]), Y(ne[0]), true]);
    else {
      const a = 2 * Math.PI * (k++) / Math.max(1, unplaced.length) - Math.PI / 2;
      placed.set(e.name, [W / 2 + Math.cos(a) * (W / 2 - 120), H / 2 + Math.sin(a) * (H / 2 - 25), false]);
    }
  }
  // links: the console's own (solid, with neighbour), direct vehicles, and relays (dashed)
  const me = placed.get(fleet.me);
  function line(a, b, dashed, label, color) {
    if (!a || !b) return;
    g.setLineDash(dashed ? [6, 5] : []); g.strokeStyle = color || "#5b6b85"; g.lineWidth = dashed ? 1.5 : 2.5;
    g.beginPath(); g.moveTo(a[0], a[1]); g.lineTo(b[0], b[1]); g.stroke(); g.setLineDash([]);
    if (label) { g.fillStyle = "#5b6b85"; g.fillText(label, (a[0] + b[0]) / 2 + 4, (a[1] + b[1]) / 2 - 4); }
  }
  const local = ents.find(e => e.name === fleet.me);
  const drawn = new Set();
  for (const l of (local && local.links) || []) {
    if (!l.neighbour) continue;
    const key = l.neighbour;
    line(me, placed.get(l.neighbour), false, drawn.has(key) ? "" : l.link, "#3567b5");
    drawn.add(key);
  }
  for (const e of ents) {
    if (e.local || e.state === "revoked") continue;
    if (e.via && e.via !== fleet.me) line(placed.get(e.via), placed.get(e.name), true, "", "#8a6fb0");
    else if (e.hops === 1 && !drawn.has(e.name)) line(me, placed.get(e.name), false, "", "#3567b5");
  }
  const labels = [];
  for (const e of ents) {
    const p = placed.get(e.name);
    let ly = p[1] + 4;  // two computers of one vehicle share a position: stack their labels
    while (labels.some(([lx, y]) => Math.abs(lx - p[0]) < 60 && Math.abs(y - ly) < 14)) ly += 15;
    labels.push([p[0], ly]);
    g.beginPath(); g.arc(p[0], p[1], e.local ? 11 : 9, 0, 2 * Math.PI);
    g.fillStyle = { alive: "#2e9d4a", stale: "#e59b23", revoked: "#8a8f99" }[e.state] || "#555";
    g.fill();
    if (e.local) { g.strokeStyle = "#1d2330"; g.lineWidth = 2; g.stroke(); }
    g.fillStyle = "#1d2330"; g.font = "bold 13px system-ui, sans-serif";
    g.fillText(e.name + (p[2] ? "" : " (no position)"), p[0] + 13, ly);
  }
}

function renderFleet(fleet) {
  state.fleet = fleet;
  drawMap(fleet);
  const tb = $("#fleet-table tbody");
  tb.replaceChildren();
  for (const e of fleet.entities) {
    const ne = localNE(e.position);
    const pos = e.position && e.position.error ? `(${e.position.error})` : ne ? `N ${ne[0].toFixed(1)} E ${ne[1].toFixed(1)} m` : "-";
    tb.append(el("tr", { "data-entity": e.name, "data-state": e.state, "data-origin": e.origin },
      el("td", {}, e.name + (e.local ? " (this console)" : "")), el("td", { class: "state-" + e.state }, e.state),
      el("td", {}, e.origin), el("td", { class: "num" }, fmt(e.hops)), el("td", {}, e.via || (e.route && e.route.next_hop) || "-"),
      el("td", { class: "num" }, e.local ? "-" : e.last_heard_s === null ? "never" : fmt(e.last_heard_s, 1) + " s ago"),
      el("td", { class: "num" }, e.route && e.route.reachable ? e.route.metric : "-"), el("td", {}, pos)));
  }
  const lb = $("#links-table tbody");
  lb.replaceChildren();
  for (const e of fleet.entities) {
    if (e.links_error) {
      lb.append(el("tr", { "data-entity": e.name }, el("td", {}, e.name), el("td", { colSpan: 5, class: "note" }, `links not shown: ${e.links_error}`)));
      continue;
    }
    for (const l of e.links || []) {
      lb.append(el("tr", { "data-entity": e.name, "data-link": l.link }, el("td", {}, e.name), el("td", {}, l.link),
        el("td", {}, l.neighbour || "-"), el("td", { class: "num" }, fmt(l.frames_in)), el("td", { class: "num" }, fmt(l.frames_out)),
        el("td", {}, l.cost !== undefined && l.cost !== null ? `cost ${l.cost}` : l.drops !== undefined ? `${l.drops} drops` : "-")));
    }
  }
  const dl = $("#entities");
  dl.replaceChildren(...fleet.entities.map(e => el("option", { value: e.name })));
  const sel = $("#var-entity");
  const cur = sel.value;
  const names = fleet.entities.filter(e => e.state !== "revoked").map(e => e.name);
  if (names.join() !== Array.from(sel.options).map(o => o.value).join()) {
    sel.replaceChildren(...names.map(n => el("option", { value: n }, n)));
    if (names.includes(cur)) sel.value = cur;
  }
}

// ---- administration table -------------------------------------------------------------------------------
function renderAdmin(a) {
  if (unchanged("admin", [a.rows.map(r => [r.row, r.content, r.source, r.destination, r.period_ms, r.type, r.status,
    r.active, r.reason, r.relayed]), a.administrators, a.certified_roles])) return;
  const admins = a.administrators, roles = a.certified_roles;
  const byName = admins === null ? "" : `Administrators by the configuration: ${admins.join(", ") || "none"}` +
    (admins.includes(a.me) ? "." : ` — ${a.me} is not one of them: targets will refuse its requests (not_authorized).`);
  // With identities the targets decide on the requester's certificate; a name list only narrows it.
  const byRole = roles === null || roles === undefined ? "" : `${a.me}'s certificate says ${roles.join(", ") || "no role"}` +
    (roles.includes("admin") ? ": targets let it administer." : ": not admin, so targets will refuse its requests for others (not_authorized).");
  const policy = $("#admin-policy");
  policy.textContent = [byRole, byName].filter(Boolean).join(" ") ||
    "No administrator list in the configuration: every target decides by its own policy.";
  policy.dataset.roles = roles ? roles.join(",") : "";
  const tb = $("#admin-table tbody");
  tb.replaceChildren();
  for (const r of a.rows) {
    const buttons = el("td", {});
    if (!r.active) buttons.append(el("button", { onclick: () => act({ op: "admin_activate", row: r.row }, refresh) }, "Activate…"));
    else buttons.append(el("button", { onclick: () => act({ op: "admin_deactivate", row: r.row }, refresh) }, "Deactivate…"));
    buttons.append(el("button", { onclick: () => {
      const v = prompt(`New period of row ${r.row} (ms)`, r.period_ms);
      if (v) act({ op: "admin_period", row: r.row, period_ms: Number(v) }, refresh);
    } }, "Period…"));
    if (!r.active) buttons.append(el("button", { onclick: () => act({ op: "admin_remove", row: r.row }, refresh) }, "Remove…"));
    tb.append(el("tr", { "data-row": r.row, "data-status": r.status },
      el("td", { class: "num" }, r.row), el("td", {}, r.content), el("td", {}, r.source), el("td", {}, r.destination),
      el("td", { class: "num" }, r.period_ms), el("td", {}, r.type), el("td", { class: "status-" + r.status }, r.status),
      el("td", { class: "reason" }, r.reason && r.reason !== "none" ? r.reason + (r.relayed ? " (relayed)" : "") : ""), buttons));
  }
}

// ---- variable browser -------------------------------------------------------------------------------------
async function openLeaf(kind, name) {
  const entity = $("#var-entity").value;
  if (!entity) { say("no entity selected", "error"); return; }
  state.varLeaf = { kind, entity, name };
  await loadLeaf();
}

async function loadLeaf() {
  const leaf = state.varLeaf;
  if (!leaf) return;
  const path = leaf.kind === "table" ? `/api/entity/${encodeURIComponent(leaf.entity)}/table/${leaf.name}`
    : leaf.kind === "offer" ? `/api/entity/${encodeURIComponent(leaf.entity)}/offer`
    : `/api/entity/${encodeURIComponent(leaf.entity)}/dir/${encodeURIComponent(leaf.name)}`;
  const d = await get(path);
  if (state.varLeaf !== leaf) return;
  $("#var-whole").classList.toggle("hidden", leaf.kind !== "dir" || !!d.error);  // only a directory read is written whole
  const title = $("#var-title");
  if (d.error) {
    title.textContent = `${leaf.entity}: ${leaf.name}: ${d.reason ? "refused (" + d.reason + ")" : d.error}`;
    title.className = "refused";
    title.dataset.reason = d.reason || "";
    $("#var-table thead").replaceChildren();
    $("#var-table tbody").replaceChildren();
    return;
  }
  title.className = "";
  title.dataset.reason = "";
  title.textContent = `${leaf.entity}: ${leaf.name} (read ${new Date().toLocaleTimeString()})`;
  if (leaf.kind === "dir") renderDir(leaf, d); else if (leaf.kind === "offer") renderOffer(leaf, d); else renderTable(leaf, d.rows);
}

function renderTable(leaf, rows) {
  const cols = rows.length ? Object.keys(rows[0]) : ["(empty)"];
  $("#var-table thead").replaceChildren(el("tr", {}, ...cols.map(c => el("th", {}, c)), el("th", {}, "")));
  const tb = $("#var-table tbody");
  tb.replaceChildren();
  for (const r of rows) {
    const tools = el("td", {});
    if (leaf.name === "pubsub") tools.append(el("button", { onclick: () => {
      const v = prompt(`Period of ${leaf.entity}'s row ${r.row} (${r.content}) in ms`, r.period_ms);
      if (v) act({ op: "set_period", entity: leaf.entity, row: r.row, period_ms: Number(v) }, loadLeaf);
    } }, "Period…"));
    if (leaf.name === "entities" && !r.local) tools.append(el("button", { onclick: () => {
      const v = prompt(`Link mask of ${leaf.entity} toward ${r.entity}`, r.mask);
      if (v) act({ op: "set_mask", entity: leaf.entity, dest: r.entity, mask: v }, loadLeaf);
    } }, "Mask…"));
    tb.append(el("tr", {}, ...cols.map(c => el("td", {}, fmt(r[c]))), tools));
  }
}

function renderDir(leaf, d) {
  $("#var-table thead").replaceChildren(el("tr", {}, el("th", {}, "field"), el("th", {}, "value"), el("th", {}, "unit"),
    el("th", {}, "description"), el("th", {}, "")));
  const tb = $("#var-table tbody");
  tb.replaceChildren();
  for (const f of d.fields) {
    const b = el("button", { onclick: () => {
      const v = prompt(`New value of ${f.field} in ${leaf.entity} (JSON)`, JSON.stringify(f.value));
      if (v === null) return;
      let parsed;
      try { parsed = JSON.parse(v); } catch (e) { parsed = v; }
      act({ op: "write", entity: leaf.entity, name: f.field, value: parsed }, loadLeaf);
    } }, "Write…");
    tb.append(el("tr", { "data-field": f.field }, el("td", {}, f.field), el("td", { class: "value" }, fmt(f.value, 6)),
      el("td", { class: "unit" }, f.unit || ""), el("td", { class: "note" }, f.doc || ""), el("td", {}, b)));
  }
  const ta = $("#var-json");
  if (document.activeElement !== ta) ta.value = JSON.stringify(d.value, null, 1);
}

function renderOffer(leaf, d) {
  $("#var-table thead").replaceChildren(el("tr", {}, el("th", {}, "directory"), el("th", {}, "type"), el("th", {}, "bytes"),
    el("th", {}, "hosted"), el("th", {}, "flows now")));
  const tb = $("#var-table tbody");
  tb.replaceChildren();
  for (const r of d.instances) {
    tb.append(el("tr", { "data-dir": r.name }, el("td", {}, r.name), el("td", {}, r.type), el("td", { class: "num" }, r.size),
      el("td", {}, r.bound === null ? "?" : r.bound ? "yes" : "no"), el("td", {}, (r.flows || []).join("; "))));
  }
  $("#var-title").textContent += ` — ${d.note || ""}`;
}

// ---- plots ---------------------------------------------------------------------------------------------------
function renderFlows(flows) {
  const tb = $("#flows-table tbody");
  const known = Array.from(tb.querySelectorAll("tr")).map(tr => tr.dataset.flow);
  if (known.join() === flows.map(f => f.content + "@" + f.source).join()) {  // same flows: update the numbers in place
    flows.forEach((f, i) => {
      const tds = tb.children[i].children;
      tds[2].textContent = f.messages; tds[3].textContent = fmt(f.rate_hz, 2);
      tds[4].textContent = fmt(f.bytes_per_s, 0); tds[5].textContent = fmt(f.jitter_ms, 2);
    });
    return;
  }
  const keep = new Map(Array.from(tb.querySelectorAll("select")).map(s => [s.dataset.key, s.value]));
  tb.replaceChildren();
  for (const f of flows) {
    const key = f.content + "@" + f.source;
    const sel = el("select", { "data-key": key }, ...(f.fields || []).map(x => el("option", { value: x },
      x + (unitOf(f.content, x) ? ` [${unitOf(f.content, x)}]` : ""))));
    if (keep.has(key)) sel.value = keep.get(key);
    const btn = el("button", { onclick: () => addSeries(f.content, f.source, sel.value) }, "Plot");
    tb.append(el("tr", { "data-flow": key }, el("td", {}, f.content), el("td", {}, f.source), el("td", { class: "num" }, f.messages),
      el("td", { class: "num rate" }, fmt(f.rate_hz, 2)), el("td", { class: "num" }, fmt(f.bytes_per_s, 0)),
      el("td", { class: "num" }, fmt(f.jitter_ms, 2)), el("td", {}, sel), el("td", {}, btn)));
  }
}

function unitOf(content, field) {
  const inst = state.catalogue && state.catalogue.instances.find(i => i.name === content);
  const u = inst && inst.units[field.replace(/\[\d+\]/g, "")];
  return u && u.unit ? u.unit : "";
}

function addSeries(content, source, field) {
  const key = `${content}@${source}:${field}`;
  if (!state.plot.series.has(key)) state.plot.series.set(key, { points: [], color: COLORS[state.plot.series.size % COLORS.length],
    unit: unitOf(content, field) });
  renderLegend();
}

function renderLegend() {
  const lg = $("#plot-legend");
  lg.replaceChildren(...Array.from(state.plot.series.entries()).map(([k, s]) =>
    el("span", { "data-series": k, "data-points": s.points.length, "data-unit": s.unit },
      el("b", {}, "■ "), `${k}${s.unit ? " [" + s.unit + "]" : ""} (${s.points.length} points)`)));
  Array.from(lg.children).forEach((c, i) => { c.firstChild.style.color = Array.from(state.plot.series.values())[i].color; });
}

async function pollSeries() {
  if (state.plot.paused || state.plot.series.size === 0) return;
  const q = Array.from(state.plot.series.keys()).map(k => "k=" + encodeURIComponent(k)).join("&");
  const d = await get(`/api/series?${q}&since=${state.plot.since}`);
  if (state.plot.paused) return;
  state.plot.since = d.t;
  const horizon = d.t - 120;
  for (const [k, pts] of Object.entries(d.series)) {
    const s = state.plot.series.get(k);
    if (!s) continue;
    for (const p of pts) s.points.push(p);
    while (s.points.length && s.points[0][0] < horizon) s.points.shift();
  }
  renderLegend();
  drawPlot(d.t);
}

function drawPlot(now, canvas, series, window_s) {
  const cv = $(canvas || "#plot"), g = cv.getContext("2d"), W = cv.width, H = cv.height;
  const win = window_s || Number($("#plot-window").value);
  series = series || state.plot.series;
  g.clearRect(0, 0, W, H);
  let lo = Infinity, hi = -Infinity;
  for (const s of series.values()) for (const [t, v] of s.points) if (t >= now - win && t <= now) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
  if (!isFinite(lo)) { g.fillStyle = "#4a5468"; g.fillText("pick a flow's field and press Plot", 20, 30); return; }
  if (hi === lo) { hi += 1; lo -= 1; }
  const pad = (hi - lo) * 0.08; hi += pad; lo -= pad;
  const L = 70, R = 10, T = 10, B = 25;
  const x = t => L + (t - (now - win)) / win * (W - L - R), y = v => T + (hi - v) / (hi - lo) * (H - T - B);
  g.strokeStyle = "#dde1e8"; g.fillStyle = "#4a5468"; g.font = "11px system-ui, sans-serif";
  for (let i = 0; i <= 4; i++) {
    const v = lo + (hi - lo) * i / 4;
    g.beginPath(); g.moveTo(L, y(v)); g.lineTo(W - R, y(v)); g.stroke();
    const near0 = Math.abs(v) < (hi - lo) * 1e-3;  // the middle of a symmetric range: 0, not 0.0000189
    g.fillText(String(near0 ? 0 : Number(v.toPrecision(3))), 4, y(v) + 4);
  }
  for (let s = 0; s <= win; s += win / 6) g.fillText(`-${(win - s).toFixed(0)} s`, x(now - win + s) - 10, H - 6);
  for (const s of series.values()) {
    g.strokeStyle = s.color; g.lineWidth = 1.5; g.beginPath();
    let first = true;
    for (const [t, v] of s.points) {
      if (t < now - win || t > now) continue;
      if (first) { g.moveTo(x(t), y(v)); first = false; } else g.lineTo(x(t), y(v));
    }
    g.stroke();
  }
}

function exportCsv() {
  const rows = ["series,unit,unix_time_s,value"];
  for (const [k, s] of state.plot.series) for (const [t, v] of s.points) rows.push(`"${k.replace(/"/g, '""')}",${s.unit},${t},${v}`);
  const blob = new Blob([rows.join("\n") + "\n"], { type: "text/csv" });
  const a = el("a", { href: URL.createObjectURL(blob), download: "uavbus-plot.csv" });
  document.body.append(a); a.click(); a.remove();
  say(`exported ${rows.length - 1} points`, "ok");
}

// ---- log review (uavbus web --log FILE): a time slider, the same plots and map ----------------------------
const review = { info: null, series: new Map() };

function startReview(info) {
  review.info = info;
  for (const b of document.querySelectorAll("nav .tab")) b.classList.toggle("hidden", b.dataset.view !== "review");
  $("#review-log").textContent = `${info.log} (recorded by ${info.node}, catalogue ${info.catalogue}, ` +
    `${((info.t1 - info.t0)).toFixed(1)} s, ${info.duplicates} duplicates left out)`;
  const slider = $("#review-t");
  slider.min = info.t0; slider.max = info.t1; slider.step = 0.05; slider.value = info.t1;
  slider.addEventListener("input", reviewAt);
  $("#review-window").addEventListener("change", reviewAt);
  const tb = $("#review-flows tbody");
  tb.replaceChildren();
  for (const f of info.flows) {
    const key = f.content + "@" + f.source;
    const sel = el("select", { "data-key": key }, ...f.fields.map(x => el("option", { value: x },
      x + (f.units[x.replace(/\[\d+\]/g, "")] ? ` [${f.units[x.replace(/\[\d+\]/g, "")]}]` : ""))));
    const btn = el("button", { onclick: () => {
      const k = `${key}:${sel.value}`;
      if (!review.series.has(k)) review.series.set(k, { points: [], color: COLORS[review.series.size % COLORS.length],
        unit: f.units[sel.value.replace(/\[\d+\]/g, "")] || "" });
      reviewAt();
    } }, "Plot");
    tb.append(el("tr", { "data-flow": key }, el("td", {}, f.content), el("td", {}, f.source), el("td", { class: "num" }, f.messages),
      el("td", { class: "num" }, fmt(f.rate_hz, 2)), el("td", {}, sel), el("td", {}, btn)));
  }
  show("review");
  reviewAt();
}

let reviewBusy = false, reviewAgain = false;
async function reviewAt() {
  if (reviewBusy) { reviewAgain = true; return; }
  reviewBusy = true;
  try {
    const t = Number($("#review-t").value), win = Number($("#review-window").value);
    $("#review-time").textContent = `${new Date(t * 1000).toISOString().replace("T", " ").slice(0, 23)} UTC ` +
      `(+${(t - review.info.t0).toFixed(2)} s)`;
    const pos = await get(`/api/review/positions?t=${t}`);
    drawMap({ me: pos.me, entities: pos.entities }, "#review-map");
    if (review.series.size) {
      const q = Array.from(review.series.keys()).map(k => "k=" + encodeURIComponent(k)).join("&");
      const d = await get(`/api/review/series?${q}&t0=${t - win}&t1=${t}`);
      for (const [k, pts] of Object.entries(d.series)) review.series.get(k).points = pts;
    }
    drawPlot(t, "#review-plot", review.series, win);
    $("#review-legend").replaceChildren(...Array.from(review.series.entries()).map(([k, s]) =>
      el("span", { "data-series": k, "data-points": s.points.length, "data-unit": s.unit },
        `■ ${k}${s.unit ? " [" + s.unit + "]" : ""}: ${s.points.length} points in the window `)));
    document.body.dataset.reviewT = String(t);
  } finally {
    reviewBusy = false;
    if (reviewAgain) { reviewAgain = false; reviewAt(); }
  }
}

// ---- refresh loop ------------------------------------------------------------------------------------------
let busy = false;
async function refresh() {
  if (busy || (state.info && state.info.mode === "review")) return;
  busy = true;
  try {
    if (state.view === "fleet" || !state.fleet) renderFleet(await get("/api/fleet"));
    if (state.view === "admin") renderAdmin(await get("/api/admin"));
    if (state.view === "plots") { renderFlows(await get("/api/flows")); }
    $("#conn").textContent = "connected · " + new Date().toLocaleTimeString();
    $("#conn").classList.remove("down");
  } catch (e) {
    $("#conn").textContent = "no answer from the console: " + e.message;
    $("#conn").classList.add("down");
  } finally { busy = false; }
}
let leafBusy = false;
async function refreshLeaf() {
  if (state.view !== "vars" || !$("#var-live").checked || !state.varLeaf || leafBusy || pendingConfirm || state.varLeaf.kind === "offer") return;
  leafBusy = true;
  try { await loadLeaf(); } catch (e) { /* shown by the next refresh */ } finally { leafBusy = false; }
}

async function start() {
  for (const b of document.querySelectorAll("nav .tab")) b.addEventListener("click", () => show(b.dataset.view));
  $("#confirm-yes").addEventListener("click", confirmYes);
  $("#confirm-no").addEventListener("click", confirmNo);
  $("#admin-form").addEventListener("submit", ev => {
    ev.preventDefault();
    act({ op: "admin_add", content: $("#adm-content").value, source: $("#adm-source").value,
      destination: $("#adm-destination").value, period_ms: Number($("#adm-period").value), kind: $("#adm-kind").value,
      activate: $("#adm-activate").checked }, refresh);
  });
  for (const b of document.querySelectorAll(".var-table")) b.addEventListener("click", () => openLeaf("table", b.dataset.table));
  $("#var-open").addEventListener("click", () => openLeaf("dir", $("#var-dir").value.trim()));
  $("#var-offer").addEventListener("click", () => openLeaf("offer", "offer"));
  $("#var-write-all").addEventListener("click", () => {
    const leaf = state.varLeaf;
    if (!leaf || leaf.kind !== "dir") { say("open a directory first", "error"); return; }
    let v;
    try { v = JSON.parse($("#var-json").value); } catch (e) { say("not JSON: " + e.message, "error"); return; }
    act({ op: "write", entity: leaf.entity, name: leaf.name, value: v }, loadLeaf);
  });
  $("#plot-pause").addEventListener("click", () => {
    state.plot.paused = !state.plot.paused;
    $("#plot-pause").textContent = state.plot.paused ? "Resume" : "Pause";
  });
  $("#plot-csv").addEventListener("click", exportCsv);
  $("#plot-clear").addEventListener("click", () => { state.plot.series.clear(); renderLegend(); });
  try {
    state.info = await get("/api/info");
    if (state.info.mode === "review") {
      $("#whoami").textContent = `review of ${state.info.log}`;
      $("#conn").textContent = "log review: no live node, nothing is sent";
      startReview(state.info);
      document.body.dataset.ready = "1";
      return;  // no live node: no refresh loop
    }
    $("#whoami").textContent = `${state.info.me} · ${state.info.system || ""} · catalogue ${state.info.catalogue}`;
    for (const m of document.querySelectorAll(".me")) m.textContent = state.info.me;
    state.catalogue = await get("/api/catalogue");
    $("#contents").replaceChildren(...state.catalogue.instances.map(i => el("option", { value: i.name })));
  } catch (e) { say(e.message, "error"); }
  show(location.hash ? location.hash.slice(1) : "fleet");
  document.body.dataset.ready = "1";  // the page is wired (tests wait for it)
  setInterval(refresh, 500);
  setInterval(refreshLeaf, 1000);
  setInterval(pollSeries, 200);
}
start();
