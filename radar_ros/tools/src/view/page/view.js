// radar view's page: reads the snapshot and then the changes from /ws, and draws the graph, the selected
// component's card and the timeline. Everything is made with DOM calls and textContent (names and payloads
// come from the robot: never parsed as HTML).
"use strict";

const SVG = "http://www.w3.org/2000/svg";
const BOX_W = 290, BOX_H = 50, ROW = 64, TOP = 20, COL_GAP = 170;
const MAX_ROWS = 500;

const view = {
  components: new Map(),   // name -> {name, kind, topics, state}
  managers: new Map(),     // manager -> [connection]
  lines: [],               // timeline, oldest first
  lastLine: 0,             // the highest line number taken
  seq: null,
  dropped: 0,
  allowAct: false,
  selected: null,
  filter: "",
  params: new Map(),       // component -> params (or null: serves none)
  actResult: null,         // {component, text, error}: what the last act came to
  violations: [],          // the rules the system broke, each once: {rule, name, why, at, components}
};
// set once per load: a test tells a reload from a live change by it
window.radarViewLoaded = Date.now();
window.radarView = view;

let dirty = { graph: true, timeline: true, card: true, rules: true };
const changedBoxes = new Set(); // components whose box shows an old state
let scheduled = false;
function schedule(what) {
  for (const w of what) dirty[w] = true;
  if (!scheduled) {
    scheduled = true;
    requestAnimationFrame(render);
  }
}

// ---- the connection ----

let socket = null;
function connect() {
  setStatus("connecting", "connecting");
  socket = new WebSocket(`ws://${location.host}/ws`);
  socket.onmessage = (e) => take(JSON.parse(e.data));
  socket.onclose = () => {
    setStatus("connecting", "reconnecting");
    setTimeout(connect, 1000);
  };
}

function setStatus(cls, text) {
  const s = document.getElementById("status");
  s.className = "status " + cls;
  s.textContent = text;
}

function take(m) {
  switch (m.type) {
    case "snapshot":
      view.components.clear();
      view.managers.clear();
      for (const c of m.components) view.components.set(c.name, c);
      for (const [k, v] of Object.entries(m.managers)) view.managers.set(k, v);
      view.lines = [];
      view.lastLine = 0;
      addLines(m.timeline);
      view.seq = m.seq;
      view.dropped = m.dropped;
      view.allowAct = !!m.allow_act;
      view.violations = m.violations || [];
      dirty.rules = true;
      document.getElementById("domain").textContent = `ROS_DOMAIN_ID ${m.domain}`;
      setStatus("live", "live");
      dirty.timelineAll = true;
      schedule(["graph", "timeline", "card"]);
      break;
    case "changes":
      if (view.seq !== null && m.seq !== view.seq + 1) {
        // a message lost: start again from a snapshot
        socket.close();
        return;
      }
      view.seq = m.seq;
      // only what changed is drawn again: the graph when its shape may have, the boxes that changed, the
      // timeline when lines came, the card when its component or the connections changed
      const what = [];
      for (const c of m.components) {
        if (!view.components.has(c.name)) what.push("graph");
        view.components.set(c.name, c);
        changedBoxes.add(c.name);
        if (c.name === view.selected) what.push("card");
      }
      if (m.gone.length || Object.keys(m.managers).length || m.managers_gone.length) what.push("graph", "card");
      for (const n of m.gone) view.components.delete(n);
      for (const [k, v] of Object.entries(m.managers)) view.managers.set(k, v);
      for (const k of m.managers_gone) view.managers.delete(k);
      if (m.timeline.length || m.dropped) what.push("timeline");
      addLines(m.timeline);
      view.dropped += m.dropped;
      if (m.violations && m.violations.length) {
        view.violations.push(...m.violations);
        what.push("rules");
        for (const v of m.violations) for (const n of v.components) changedBoxes.add(n);
      }
      schedule(what.length ? what : ["boxes"]);
      break;
    case "params":
      view.params.set(m.component, m.params);
      schedule(["card"]);
      break;
    case "acted":
      actResult(`${m.slot} sent to ${m.component}`, false, m.component);
      break;
    case "error":
      actResult(m.message, true);
      break;
  }
}

function addLines(lines) {
  for (const l of lines) {
    // a snapshot may hold lines the next changes send again
    if (l.n <= view.lastLine) continue;
    view.lastLine = l.n;
    view.lines.push(l);
  }
  if (view.lines.length > MAX_ROWS) view.lines.splice(0, view.lines.length - MAX_ROWS);
}

// ---- what is shown ----

function inFilter(name) {
  const f = view.filter.replace(/\/+$/, "");
  return f === "" || name === f || name.startsWith(f + "/");
}

function split(topic) {
  const i = topic.lastIndexOf("/");
  return i > 0 ? [topic.slice(0, i), topic.slice(i + 1)] : [topic, ""];
}

// every connection once (a program node and its manager list the same ones)
function connections() {
  const seen = new Set(), out = [];
  for (const [manager, list] of view.managers) {
    for (const k of list || []) {
      const key = `${k.id} ${k.source} ${k.target} ${k.kind_label}`;
      if (seen.has(key)) continue;
      seen.add(key);
      const [source, signal] = split(k.source);
      let [target, slot] = split(k.target);
      if (k.target === "(anonymous)") { target = `${manager} (anonymous slot)`; slot = "call"; }
      out.push({ ...k, manager, sourceNode: source, signal, targetNode: target, slot,
                 untilNode: k.until ? split(k.until)[0] : null });
    }
  }
  return out;
}

function stateText(c) {
  const s = c.state;
  if (c.kind === "topic") return "topic";
  if (!s) return "no state yet";
  if (c.kind === "event") {
    return `${s.active ? "active" : "inactive"} · ${s.triggers} triggers · ${s.listeners} listeners`;
  }
  const last = s.last_exit_reason ? ` · last: ${s.last_exit_reason}` : "";
  return `${s.state_label} · ${s.starts} starts${last}`;
}

function stateClass(c) {
  if (c.kind === "event") return c.state && c.state.active ? "active" : "inactive";
  if (c.kind === "response") return c.state ? c.state.state_label : "unknown";
  return "";
}

function el(ns, tag, attrs, text) {
  const e = ns ? document.createElementNS(ns, tag) : document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
  if (text !== undefined) e.textContent = text;
  return e;
}

// ---- the graph ----

const boxes = new Map(); // name -> {g, stateText, x, y}

function drawGraph() {
  const svg = document.getElementById("graph");
  svg.replaceChildren();
  boxes.clear();
  const edges = connections().filter((e) => inFilter(e.sourceNode) || inFilter(e.targetNode));
  const nodes = new Map();
  for (const c of view.components.values()) if (inFilter(c.name)) nodes.set(c.name, c);
  for (const e of edges) {
    for (const n of [e.sourceNode, e.targetNode, e.untilNode]) {
      if (n && !nodes.has(n)) nodes.set(n, view.components.get(n) || { name: n, kind: "topic" });
    }
  }
  const columns = { event: [], topic: [], response: [] };
  for (const c of [...nodes.values()].sort((a, b) => a.name.localeCompare(b.name))) {
    (columns[c.kind] || columns.topic).push(c);
  }
  const order = ["event", "topic", "response"].filter((k) => columns[k].length > 0);
  let rows = 0;
  order.forEach((kind, col) => {
    columns[kind].forEach((c, row) => {
      const x = 20 + col * (BOX_W + COL_GAP), y = TOP + row * ROW;
      boxes.set(c.name, { x, y, c });
      rows = Math.max(rows, row + 1);
    });
  });
  const width = 40 + order.length * (BOX_W + COL_GAP);
  svg.setAttribute("width", Math.max(width, 400));
  svg.setAttribute("height", TOP * 2 + Math.max(rows, 1) * ROW);
  const defs = el(SVG, "defs");
  for (const [id, colour] of [["arrow", "#57606a"], ["arrow-until", "#d1242f"]]) {
    const m = el(SVG, "marker", { id, viewBox: "0 0 10 10", refX: 10, refY: 5, markerWidth: 7, markerHeight: 7,
                                  orient: "auto-start-reverse" });
    m.appendChild(el(SVG, "path", { d: "M0,0 L10,5 L0,10 z", fill: colour }));
    defs.appendChild(m);
  }
  svg.appendChild(defs);
  const edgeLayer = el(SVG, "g", { id: "edges" });
  svg.appendChild(edgeLayer);
  // the edges into one box (connections and their untils) spread over its side, each its own slot
  const into = new Map(), slot = new Map();
  const ends = [];
  for (const e of edges) {
    ends.push([e, "to"]);
    if (e.untilNode) ends.push([e, "until"]);
  }
  // in the order of their sources from the top, so that they do not cross on the way in
  const fromY = ([e, which]) => (boxes.get(which === "to" ? e.sourceNode : e.untilNode) || { y: 0 }).y;
  ends.sort((p, q) => fromY(p) - fromY(q));
  for (const [e, which] of ends) {
    const n = (into.get(e.targetNode) || 0) + 1;
    into.set(e.targetNode, n);
    slot.set(`${e.id} ${e.manager} ${which}`, n);
  }
  entryY = (e, which) => {
    const n = into.get(e.targetNode) || 1, k = slot.get(`${e.id} ${e.manager} ${which}`) || 1;
    return (BOX_H * k) / (n + 1);
  };
  for (const e of edges) {
    drawEdge(edgeLayer, e.sourceNode, e.targetNode, entryY(e, "to"), e.kind_label + (e.state_label !== "armed" ? " waiting" : ""),
             `${e.kind_label} ${e.signal} → ${e.slot} #${e.id}`,
             `${e.manager}: ${e.state_label}, ${e.delivered} delivered${e.departure ? ", " + e.departure : ""}`,
             { "data-connection": e.id, "data-kind": e.kind_label });
    if (e.untilNode) drawEdge(edgeLayer, e.untilNode, e.targetNode, entryY(e, "until"), "until", `until #${e.id}`, `${e.manager}: until`,
                              { "data-until": e.id });
  }
  for (const [name, b] of boxes) {
    const c = b.c;
    const g = el(SVG, "g", { class: `node ${c.kind}`, transform: `translate(${b.x},${b.y})`, "data-component": name });
    g.appendChild(el(SVG, "rect", { width: BOX_W, height: BOX_H, rx: 8 }));
    g.appendChild(el(SVG, "text", { class: "name", x: 10, y: 20 }, name));
    b.stateText = el(SVG, "text", { class: "state", x: 10, y: 38 });
    g.appendChild(b.stateText);
    g.addEventListener("click", () => select(name));
    b.g = g;
    svg.appendChild(g);
    updateBox(name);
  }
}

// `dy`: where on the target's side the edge goes in
let entryY = () => BOX_H / 2;
function drawEdge(layer, from, to, dy, cls, label, tip, data) {
  const a = boxes.get(from), b = boxes.get(to);
  if (!a || !b) return;
  const x1 = a.x + BOX_W, y1 = a.y + BOX_H / 2;
  let d, lx, ly;
  if (b.x > a.x) {
    const x2 = b.x, y2 = b.y + dy, mx = (x1 + x2) / 2;
    d = `M${x1},${y1} C${mx},${y1} ${mx},${y2} ${x2},${y2}`;
    lx = mx; ly = (y1 + y2) / 2 - 4;
  } else {
    // same column or backwards: out of the right side and back in
    const x2 = b.x + BOX_W, y2 = b.y + dy, out = Math.max(x1, x2) + 70;
    d = `M${x1},${y1} C${out},${y1} ${out},${y2} ${x2},${y2}`;
    lx = out - 30; ly = (y1 + y2) / 2;
  }
  const marker = cls === "until" ? "url(#arrow-until)" : "url(#arrow)";
  const path = el(SVG, "path", { class: `edge ${cls}`, d, "marker-end": marker, ...data });
  path.appendChild(el(SVG, "title", {}, tip));
  layer.appendChild(path);
  const t = el(SVG, "text", { class: "edge-label", x: lx, y: ly, "text-anchor": "middle" }, label);
  layer.appendChild(t);
}

function broke(name) {
  return view.violations.filter((v) => v.components.includes(name));
}
function updateBox(name) {
  const b = boxes.get(name);
  if (!b) return;
  const c = view.components.get(name) || b.c;
  b.c = c;
  const selected = name === view.selected ? " selected" : "";
  const broken = broke(name);
  b.g.setAttribute("class", `node ${c.kind} ${stateClass(c)}${selected}${broken.length ? " broken" : ""}`);
  if (broken.length) b.g.setAttribute("data-broken", broken.map((v) => v.rule).join(" "));
  else b.g.removeAttribute("data-broken");
  b.g.setAttribute("data-state", c.kind === "response" && c.state ? c.state.state_label : stateClass(c));
  b.stateText.textContent = stateText(c);
}

// ---- the card ----

function select(name) {
  view.selected = name;
  const c = view.components.get(name);
  if (c && c.kind !== "topic" && socket && socket.readyState === WebSocket.OPEN) {
    socket.send(JSON.stringify({ op: "params", component: name }));
  }
  schedule(["graph", "card"]);
}

function kvTable(obj) {
  const t = el(null, "table", { class: "kv" });
  for (const [k, v] of Object.entries(obj)) {
    const tr = el(null, "tr");
    tr.appendChild(el(null, "td", {}, k));
    tr.appendChild(el(null, "td", {}, typeof v === "object" ? JSON.stringify(v) : String(v)));
    t.appendChild(tr);
  }
  return t;
}

function drawCard() {
  const card = document.getElementById("card");
  const name = view.selected;
  const c = name && view.components.get(name);
  if (!c) {
    card.replaceChildren(el(null, "p", { class: "hint" },
      name ? `${name} is not on the graph now.` : "Click a component to see its state, connections and parameters."));
    return;
  }
  // keep what is being typed in the payload box
  const typed = document.getElementById("payload");
  const payload = typed ? typed.value : "";
  const parts = [el(null, "div", { class: "card-name" }, c.name), el(null, "div", { class: "hint" }, c.kind)];
  if (c.state) {
    const s = { ...c.state };
    delete s.name;
    if (s.stamp) s.stamp = new Date(s.stamp.sec * 1000 + s.stamp.nanosec / 1e6).toISOString();
    const sec = el(null, "div", { class: "card-section" });
    sec.appendChild(el(null, "h2", {}, "State"));
    sec.appendChild(kvTable(s));
    parts.push(sec);
  }
  if (c.kind === "response") {
    const sec = el(null, "div", { class: "card-section" });
    sec.appendChild(el(null, "h2", {}, "Act"));
    const act = el(null, "div", { class: "act" });
    const input = el(null, "input", { id: "payload", placeholder: `start payload (YAML), e.g. {} ; ${c.topics.start ? c.topics.start.type : ""}` });
    input.value = payload;
    act.appendChild(input);
    for (const slot of ["start", "interrupt", "exit"]) {
      const b = el(null, "button", { id: `act-${slot}`, "data-slot": slot }, slot);
      if (!view.allowAct) {
        b.disabled = true;
        b.title = "acting is off: start radar view with --allow-act";
      }
      b.addEventListener("click", () => {
        const p = slot === "start" ? document.getElementById("payload").value : "";
        socket.send(JSON.stringify({ op: "act", slot, component: c.name, payload: p }));
      });
      act.appendChild(b);
    }
    sec.appendChild(act);
    const said = view.actResult && view.actResult.component === c.name ? view.actResult : null;
    sec.appendChild(el(null, "div", { id: "act-result", class: said && said.error ? "error" : "" },
      !view.allowAct ? "Acting is off (radar view --allow-act)." : said ? said.text : ""));
    parts.push(sec);
  }
  const touching = connections().filter((e) => [e.sourceNode, e.targetNode, e.untilNode].includes(c.name));
  const conn = el(null, "div", { class: "card-section" });
  conn.appendChild(el(null, "h2", {}, `Connections (${touching.length})`));
  for (const e of touching) {
    conn.appendChild(el(null, "div", {},
      `#${e.id} ${e.kind_label} ${e.source} → ${e.target}${e.until ? " until " + e.until : ""} (${e.state_label}, ${e.delivered} delivered; ${e.manager})`));
  }
  parts.push(conn);
  const params = el(null, "div", { class: "card-section" });
  params.appendChild(el(null, "h2", {}, "Parameters"));
  const p = view.params.get(c.name);
  params.appendChild(p === undefined ? el(null, "div", { class: "hint" }, "asking ...")
    : p === null ? el(null, "div", { class: "hint" }, "serves none")
    : kvTable(p));
  parts.push(params);
  const topics = el(null, "div", { class: "card-section" });
  topics.appendChild(el(null, "h2", {}, "Topics"));
  topics.appendChild(kvTable(Object.fromEntries(Object.entries(c.topics || {}).map(([k, v]) => [k, `${v.topic} (${v.type})`]))));
  parts.push(topics);
  const had = document.activeElement && document.activeElement.id === "payload";
  card.replaceChildren(...parts);
  if (had) document.getElementById("payload").focus();
}

// what the last act from this page came to, kept for the card (drawn again at every change)
function actResult(text, error, component) {
  view.actResult = { component: component || view.selected, text, error };
  schedule(["card"]);
}

// ---- the timeline ----

function fmtTime(ns) {
  if (!ns) return "";
  const d = new Date(ns / 1e6);
  return d.toLocaleTimeString([], { hour12: false }) + "." + String(d.getMilliseconds()).padStart(3, "0");
}

// newest first, in the order they were sent (they come in on several topics, so not quite in that order): new
// lines go on top; the table is made again only when one is older than the newest shown, or the filter changed
let shownTo = 0, shownNewest = -Infinity;
const byTime = (a, b) => (a.t || 0) - (b.t || 0) || a.n - b.n;
function lineRow(l) {
  const tr = el(null, "tr", { "data-component": l.component, "data-signal": l.signal, "data-n": l.n });
  tr.appendChild(el(null, "td", { class: "time" }, fmtTime(l.t)));
  tr.appendChild(el(null, "td", {}, l.component));
  tr.appendChild(el(null, "td", {}, l.signal));
  const text = JSON.stringify(l.payload);
  tr.appendChild(el(null, "td", { class: "payload", title: text }, text));
  return tr;
}
function drawTimeline(all) {
  const body = document.querySelector("#timeline tbody");
  const fresh = view.lines.filter((l) => l.n > shownTo && inFilter(l.component)).sort(byTime);
  if (all || (fresh.length && (fresh[0].t || 0) < shownNewest)) {
    const shown = view.lines.filter((l) => inFilter(l.component)).sort(byTime).reverse();
    body.replaceChildren(...shown.map(lineRow));
    shownNewest = shown.length ? (shown[0].t || 0) : -Infinity;
  } else {
    for (const l of fresh) {
      body.insertBefore(lineRow(l), body.firstChild);
      shownNewest = Math.max(shownNewest, l.t || 0);
    }
    while (body.children.length > MAX_ROWS) body.removeChild(body.lastChild);
  }
  if (view.lines.length) shownTo = view.lines[view.lines.length - 1].n;
  document.getElementById("dropped").textContent =
    view.dropped ? `(${view.dropped} signals not shown: more than the page's update bound)` : "";
}

// ---- the rules broken ----

function drawRules() {
  const list = document.getElementById("violations");
  list.replaceChildren(...view.violations.map((v) => {
    const li = el(null, "li", { "data-rule": v.rule, "data-name": v.name });
    li.appendChild(el(null, "span", { class: "rule" }, `${v.rule} ${v.name}`));
    li.appendChild(document.createTextNode(` at ${fmtTime(v.at)}: ${v.why}`));
    return li;
  }));
  document.getElementById("rules-pane").hidden = view.violations.length === 0;
}

// ---- render ----

let graphShape = "";
function render() {
  scheduled = false;
  // the graph is drawn again only when its shape changed; otherwise only the boxes that changed
  let drawn = false;
  if (dirty.graph) {
    const shape = JSON.stringify([view.filter, view.selected, [...view.components.keys()],
      connections().map((e) => [e.id, e.source, e.target, e.until, e.state_label, e.delivered])]);
    if (shape !== graphShape) {
      graphShape = shape;
      drawGraph();
      drawn = true;
    }
    document.getElementById("counts").textContent =
      `${view.components.size} components, ${connections().length} connections`;
  }
  if (!drawn) for (const name of changedBoxes) updateBox(name);
  changedBoxes.clear();
  if (dirty.timeline) drawTimeline(dirty.timelineAll);
  if (dirty.card) drawCard();
  if (dirty.rules) drawRules();
  dirty = { graph: false, timeline: false, card: false, rules: false };
}

document.getElementById("filter").addEventListener("input", (e) => {
  view.filter = e.target.value.trim();
  dirty.timelineAll = true;
  schedule(["graph", "timeline"]);
});

connect();
