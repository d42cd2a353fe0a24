// The operator console: a live run over server-sent events, or a finished run with a time slider.
// Plain JavaScript, no build step; every request goes to this console's own origin.
"use strict";

const hash = new URLSearchParams(location.hash.slice(1));
const token = hash.get("token") || sessionStorage.getItem("console-token") || "";
if (hash.get("token")) sessionStorage.setItem("console-token", token);

const state = { live: false, mission: null, events: [], worlds: [], telemetry: [], lastSample: null,
  minBattery: null, rate: null, casualty: null, latencies: [] };
window.consoleState = state;  // for tests and for a person at the devtools

function el(tag, cls, text) {
  const node = document.createElement(tag);
  if (cls) node.className = cls;
  if (text !== undefined && text !== null) node.textContent = String(text);
  return node;
}
function tip(text) { return el("span", "", text); }  // a tooltip as text: names from files are never HTML
function num(x, digits) { return typeof x === "number" ? x.toFixed(digits) : "–"; }

async function api(path) {
  const r = await fetch(path, { headers: { Authorization: "Bearer " + token } });
  if (!r.ok) throw new Error(path + ": " + r.status);
  return r.json();
}
async function post(path, body) {
  const r = await fetch(path, { method: "POST", headers: { Authorization: "Bearer " + token,
    "Content-Type": "application/json" }, body: JSON.stringify(body || {}) });
  const answer = await r.json().catch(() => ({}));
  if (!r.ok) setStatus("refused: " + (answer.error || r.status));
  return answer;
}
function setStatus(text) { document.getElementById("status").textContent = text; }

// ---- the map: an offline basemap from the scene, the mission, the vehicle ----
const map = L.map("map", { zoomControl: true, attributionControl: true, zoomSnap: 0.25, maxZoom: 22 });
map.attributionControl.setPrefix("Leaflet (offline; basemap drawn from the scene)");
map.setView([21.4133, 39.8933], 17);
map.createPane("ground").style.zIndex = 250;  // the rendered ground: above the (empty) tile pane, under the vectors
const layers = { ground: L.layerGroup().addTo(map), scene: L.layerGroup().addTo(map), mission: L.layerGroup().addTo(map),
  world: L.layerGroup().addTo(map), trail: L.polyline([], { color: "#1565c0", weight: 2 }).addTo(map) };
L.control.layers(null, { "ground picture": layers.ground, "scene": layers.scene }, { collapsed: false }).addTo(map);
const ZONE_COLOURS = { walkway: "#b9a78a", camp: "#c9b48f", plaza: "#cdbf9f" };
let vehicle = null;

// The scene's ground rendered straight down, under the vectors: fetched after the page with the token (an <img>
// cannot send it) and shown as a data: URL (the CSP's img-src); once per run, dropped if another run opened meanwhile.
async function drawGround(scene) {
  const runId = state.runId;
  if (!scene.ground || !runId || state.groundOf === runId) return;
  state.groundOf = runId;
  layers.ground.clearLayers();
  try {
    const r = await fetch(`/api/runs/${encodeURIComponent(runId)}/ground.png`,
      { headers: { Authorization: "Bearer " + token } });
    if (!r.ok) return;
    const blob = await r.blob();
    const url = await new Promise((done, fail) => {
      const reader = new FileReader();
      reader.onload = () => done(reader.result); reader.onerror = fail; reader.readAsDataURL(blob);
    });
    if (state.runId !== runId) return;
    L.imageOverlay(url, scene.ground.bounds, { pane: "ground", className: "ground-picture", alt: "ground" })
      .addTo(layers.ground);
  } catch (err) { state.groundOf = null; }
}

function drawScene(scene) {
  state.scene = scene;
  layers.scene.clearLayers();
  if (!scene) { layers.ground.clearLayers(); state.groundOf = null; return; }
  drawGround(scene);
  for (const z of scene.zones) {
    L.polygon(z.polygon, { color: "#8d7b5a", weight: 1, fillColor: ZONE_COLOURS[z.kind] || "#c8bda5",
      fillOpacity: 0.45 }).bindTooltip(tip(`${z.name || z.id} (${z.kind}, ${z.density} /m²)`)).addTo(layers.scene);
  }
  for (const m of scene.landmarks) {
    if (m.polygon) L.polygon(m.polygon, { color: "#5b6b3a", weight: 1, fillOpacity: 0.3 }).addTo(layers.scene);
    L.circleMarker(m.at, { radius: 4, color: "#3b4a2a", weight: 1, fillColor: "#8da05b", fillOpacity: 0.9 })
      .bindTooltip(tip(`${m.name || m.id} (${m.kind})`)).addTo(layers.scene);
  }
  L.circleMarker(scene.home, { radius: 6, color: "#000", fillColor: "#fff", fillOpacity: 1 })
    .bindTooltip(tip("home")).addTo(layers.scene);
}

function drawMission(mission, home) {
  layers.mission.clearLayers();
  if (!mission) return;
  state.minBattery = mission.min_battery_pct;
  const fence = mission.geofence;
  if (fence && fence.center) L.circle(fence.center, { radius: fence.radius_m, color: "#b3261e", weight: 2,
    dashArray: "6 6", fill: false }).bindTooltip(tip(`geofence, ceiling ${mission.ceiling_m ?? "–"} m`)).addTo(layers.mission);
  if (fence && fence.polygon) L.polygon(fence.polygon, { color: "#b3261e", weight: 2, dashArray: "6 6",
    fill: false }).bindTooltip(tip(`geofence, ceiling ${mission.ceiling_m ?? "–"} m`)).addTo(layers.mission);
  const legs = mission.legs.filter((l) => !l.trigger);
  const path = (home ? [home] : []).concat(legs.map((l) => l.at));
  if (path.length > 1) L.polyline(path, { color: "#6a1b9a", weight: 2, dashArray: "3 5" }).addTo(layers.mission);
  for (const l of legs) L.circleMarker(l.at, { radius: 5, color: "#6a1b9a", fillOpacity: 0.6 })
    .bindTooltip(tip(`${l.step} (${l.action})`)).addTo(layers.mission);
  const bounds = L.latLngBounds(path.length ? path : [[21.4133, 39.8933]]);
  map.fitBounds(bounds.pad(0.25), { animate: false });
}

function vehicleIcon(yaw) {
  return L.divIcon({ className: "vehicle", iconSize: [26, 26], iconAnchor: [13, 13],
    html: `<svg width="26" height="26" viewBox="-13 -13 26 26"><g transform="rotate(${Number(yaw) || 0})">` +
      `<path d="M0,-12 L8,9 L0,4 L-8,9 Z" fill="#0d47a1" stroke="#fff" stroke-width="1.5"/></g></svg>` });
}

function showVehicle(s) {
  if (!s) return;
  const at = [s.lat_deg, s.lon_deg];
  if (!vehicle) vehicle = L.marker(at, { icon: vehicleIcon(s.yaw_deg), zIndexOffset: 1000 }).addTo(map);
  else { vehicle.setLatLng(at); vehicle.setIcon(vehicleIcon(s.yaw_deg)); }
}

// The 2-sigma ellipse of a position's covariance (m², north/east), as a polygon of latitudes and longitudes.
function ellipse(lat, lon, cov) {
  const a = Math.max(cov[0][0], 1e-4), b = cov[0][1], c = Math.max(cov[1][1] - (b * b) / a, 1e-4);
  const l11 = Math.sqrt(a), l21 = b / l11, l22 = Math.sqrt(c);  // Cholesky: cov = L Lᵀ
  const mLat = 111320, mLon = 111320 * Math.cos((lat * Math.PI) / 180);
  const points = [];
  for (let i = 0; i < 24; i++) {
    const t = (2 * Math.PI * i) / 24, x = 2 * Math.cos(t), y = 2 * Math.sin(t);
    points.push([lat + (l11 * x) / mLat, lon + (l21 * x + l22 * y) / mLon]);
  }
  return points;
}

function drawWorld(world) {
  state.shownWorld = world;
  layers.world.clearLayers();
  if (!world) return;
  const isolated = new Set(world.relations.filter((r) => r.pred === "isolated_from").map((r) => r.subj));
  const at = {};
  for (const o of world.objects) if (typeof o.lat === "number") at[o.id] = [o.lat, o.lon];
  for (const m of (state.scene && state.scene.landmarks) || []) at[m.id] = m.at;
  for (const r of world.relations) {  // near: a line to what it is near (a landmark, another object)
    if (r.pred === "near" && at[r.subj] && at[r.obj]) L.polyline([at[r.subj], at[r.obj]], { color: "#7b8794",
      weight: 1, dashArray: "2 4" }).bindTooltip(tip(`${r.subj} near ${r.obj}`)).addTo(layers.world);
  }
  for (const o of world.objects) {
    if (typeof o.lat !== "number") continue;
    const casualty = state.casualty === o.id;
    const colour = casualty ? "#b3261e" : o.class === "person" ? (isolated.has(o.id) ? "#d08700" : "#37474f") : "#455a64";
    const shape = o.cov ? L.polygon(ellipse(o.lat, o.lon, o.cov)) : L.circle([o.lat, o.lon], { radius: 1 });
    shape.setStyle({ color: colour, weight: casualty ? 3 : 1, fillOpacity: 0.25 });
    shape.addTo(layers.world);
    L.circleMarker([o.lat, o.lon], { radius: 2, color: colour, weight: 1, fillOpacity: 1 }).addTo(layers.world)
      .bindTooltip(tip(`${o.id} ${o.class} conf ${num(o.conf, 2)}${isolated.has(o.id) ? ", isolated" : ""}` +
        `${casualty ? ", CASUALTY" : ""}`), { permanent: casualty, direction: "left", offset: [-8, 0] });
  }
}

// ---- telemetry strip ----
function showTelemetry(s) {
  const box = document.getElementById("telemetry");
  box.replaceChildren();
  if (!s) return;
  const speed = Math.hypot(s.vn_mps || 0, s.ve_mps || 0);
  const low = state.minBattery != null && s.battery_pct != null && s.battery_pct < state.minBattery;
  const cells = [["alt m", num(s.alt_m, 1)], ["speed m/s", num(speed, 1)],
    ["battery %", `${num(s.battery_pct, 0)}${state.minBattery != null ? " / " + state.minBattery : ""}`, low],
    ["mode", s.mode], ["armed", s.armed ? "yes" : "no"], ["landed", s.landed_state],
    ["GPS fix, sats", s.gps_fix_type != null ? `${s.gps_fix_type}, ${s.gps_satellites ?? "?"}` : "–"],
    ["sim t", `${num(s.time_s, 1)} s`], ["sim speed", state.live && state.rate ? "×" + num(state.rate, 1) : "–"], linkCell()];
  for (const [name, value, warn] of cells) {
    const cell = el("div", warn ? "warn" : "");
    cell.append(el("span", "", name), el("b", "", value));
    box.append(cell);
  }
}

function linkCell() {  // live: how long since the vehicle's last sample reached this page
  if (!state.live) return ["link", "replay"];
  const silent = state.heardAt ? (performance.now() - state.heardAt) / 1000 : null;
  return ["link", silent === null ? "–" : silent < 2 ? "ok" : `silent ${num(silent, 0)} s`, silent !== null && silent >= 2];
}
setInterval(() => { if (state.live && !state.over) showTelemetry(state.lastSample); }, 1000);

// ---- the agent's timeline ----
const SHOWN = new Set(["run", "tool", "decision", "trigger", "mission", "refusal", "plan", "reflection",
  "approval", "control", "failsafe", "fault", "alert", "log"]);

function eventNode(e) {
  const node = el("div", "ev " + e.kind);
  node.dataset.seq = e.seq;
  node.append(el("span", "t", `${num(e.sim_t, 1)} `), el("span", "k", e.kind), el("span", "", e.summary || ""));
  const a = e.assessment;
  if (e.kind === "decision" && a) {
    const why = el("div", "why");
    why.append(el("span", "sev-" + a.severity, a.severity), el("span", "", ` · confidence ${num(a.confidence, 2)} · `),
      el("span", "", a.rationale || ""));
    node.append(why);
  }
  if (e.kind === "refusal" && e.error) node.append(el("div", "why", e.error));
  if (e.kind === "tool" && e.status && e.status !== "ok") node.append(el("div", "why", `${e.status}: ${e.error || ""}`));
  if (e.kind === "control") node.append(el("div", "why", `by ${e.by}${e.reason ? ": " + e.reason : ""}`));
  node.addEventListener("click", () => drawWorld(worldAt(e.sim_t)));
  return node;
}

function addEvent(e) {
  state.events.push(e);
  if (e.kind === "decision" && e.assessment && e.assessment.severity === "critical" && e.assessment.subject_id)
    state.casualty = e.assessment.subject_id;
  if (!SHOWN.has(e.kind)) return;
  const list = document.getElementById("timeline");
  list.prepend(eventNode(e));
  while (list.childElementCount > 800) list.lastChild.remove();
  if (e.kind === "run" && e.event === "end") setStatus(`${state.runId}: ${e.outcome}`);
}

function worldAt(t) {
  let best = null;
  for (const w of state.worlds) if (w.t != null && (t == null || w.t <= t + 0.01)) best = w;
  return best || state.worlds[state.worlds.length - 1] || null;
}

// ---- approvals and control ----
function addQuestion(q) {
  if (document.getElementById("q-" + q.id)) return;
  const card = el("div", "card");
  card.id = "q-" + q.id;
  const r = q.request || {};
  card.append(el("div", "", r.question || `approve ${r.step}?`));
  if (r.args) card.append(el("div", "why", Object.entries(r.args).map(([k, v]) => `${k}=${v}`).join(", ")));
  const reason = el("input");
  reason.placeholder = "reason (for a decline)";
  // edit the arguments before approving: only the step's own arguments; the envelope checks them when they fly
  const edit = el("details", "edit"), args = el("textarea"), problem = el("div", "why");
  edit.append(el("summary", "", "edit arguments"), args, problem);
  args.value = JSON.stringify(r.args || {}, null, 1);
  args.rows = 3;
  const yes = el("button", "approve", "Approve"), no = el("button", "decline", "Decline");
  yes.addEventListener("click", () => {
    const body = { approve: true, reason: reason.value || null };
    if (edit.open) {
      let edited;
      try { edited = JSON.parse(args.value); } catch (e) { problem.textContent = "not JSON: " + e.message; return; }
      const changed = Object.fromEntries(Object.entries(edited || {}).filter(
        ([k, v]) => JSON.stringify(v) !== JSON.stringify((r.args || {})[k])));
      if (Object.keys(changed).length) body.args = changed;
    }
    post(`/api/questions/${q.id}`, body).then((a) => { if (a.error) problem.textContent = "refused: " + a.error; });
  });
  no.addEventListener("click", () => post(`/api/questions/${q.id}`, { approve: false, reason: reason.value || null }));
  card.append(reason, yes, el("span", "", " "), no, edit);
  document.getElementById("approvals").append(card);
  const s = state.lastSample;  // a decision to make: show where it is being made
  if (state.live && s) map.setView([s.lat_deg, s.lon_deg], 18.5, { animate: false });
}
function dropQuestion(id) { const c = document.getElementById("q-" + id); if (c) c.remove(); }

for (const b of document.querySelectorAll("#controls button")) {
  b.addEventListener("click", () => post(`/api/control/${b.dataset.command}`, {}));
}

// ---- live ----
function live() {
  state.live = true;
  document.getElementById("controls").hidden = false;
  const source = new EventSource(`/api/live/stream?token=${encodeURIComponent(token)}`);
  let lastRate = null;
  source.onmessage = (m) => {
    const { type, data } = JSON.parse(m.data);
    if (type === "snapshot") {
      state.runId = data.run_id;
      drawScene(data.scene);
      drawMission(data.mission, data.scene && data.scene.home);
      document.getElementById("timeline").replaceChildren();
      document.getElementById("approvals").replaceChildren();
      state.events = [];
      data.events.forEach(addEvent);
      layers.trail.setLatLngs(data.trail.map((p) => [p[1], p[2]]));
      if (data.world) { state.worlds = [data.world]; drawWorld(data.world); }
      data.questions.forEach(addQuestion);
      state.lastSample = data.telemetry;
      if (data.telemetry) state.heardAt = performance.now();
      showVehicle(data.telemetry); showTelemetry(data.telemetry);
      setStatus(`${data.run_id}: live`);
    } else if (type === "event") {
      if (typeof data.t === "number") {  // publication to this page, on this machine's clock (benchmarks/console.py)
        state.latencies.push(Date.now() - data.t * 1000);
        if (state.latencies.length > 5000) state.latencies.shift();
      }
      addEvent(data);
    }
    else if (type === "telemetry") {
      const now = performance.now() / 1000;
      if (lastRate && data.time_s > lastRate[1]) state.rate = (data.time_s - lastRate[1]) / (now - lastRate[0]);
      lastRate = [now, data.time_s];
      state.lastSample = data;
      state.heardAt = performance.now();
      state.received = (state.received || 0) + 1;
      layers.trail.addLatLng([data.lat_deg, data.lon_deg]);
      showVehicle(data); showTelemetry(data);
    } else if (type === "world") {
      state.worlds.push(data);
      if (state.worlds.length > 600) state.worlds.shift();
      drawWorld(data);
    } else if (type === "question") addQuestion(data);
    else if (type === "answered") dropQuestion(data.id);
  };
  source.addEventListener("end", () => {
    source.close(); state.over = true; setStatus(`${state.runId}: the run is over`);
  });
}

// ---- replay (a run still flying in another process is re-read every 2 s, the slider kept at its end) ----
let following = null;

async function openRun(id, keepView, waitFor) {  // waitFor: re-reads to wait for a resumed run to speak
  const run = await api(`/api/runs/${encodeURIComponent(id)}`);
  leaveSwarm();
  const slider = document.getElementById("slider");
  const atEnd = !keepView || Number(slider.value) >= Number(slider.max) - Number(slider.step);  // a value snaps to a step
  const still = keepView && state.replayed === id && run.events.length === state.replayedEvents &&
    run.telemetry.length === state.replayedSamples;  // no news since the last read: stopped, not flying
  state.live = false; state.runId = id; state.casualty = null; state.events = [];
  state.telemetry = run.telemetry; state.worlds = run.worlds; state.checkpoints = run.checkpoints || [];
  state.replayed = id; state.replayedEvents = run.events.length; state.replayedSamples = run.telemetry.length;
  document.getElementById("controls").hidden = true;
  document.getElementById("approvals").replaceChildren();
  if (!keepView) { drawScene(run.scene); drawMission(run.mission, run.scene && run.scene.home); }
  const times = run.telemetry.map((s) => s.time_s);
  slider.min = times.length ? times[0] : 0;
  slider.max = times.length ? times[times.length - 1] : 0;
  if (atEnd) slider.value = slider.max;
  document.getElementById("replay").hidden = false;
  slider.oninput = () => replayAt(run, Number(slider.value));
  const runEvents = run.events.filter((e) => e.kind === "run");  // a resumed run speaks again after its end
  const ended = runEvents.length > 0 && runEvents[runEvents.length - 1].event === "end";
  document.getElementById("resume-run").hidden = !(ended || still);
  document.getElementById("fork-run").hidden = !(ended || still) || !state.checkpoints.length;
  replayAt(run, Number(slider.value));
  const origin = run.forked_from ? ` (fork of ${run.forked_from.run_id} at ${num(run.forked_from.sim_t, 1)} s)` : "";
  setStatus(`${id}${origin}: ${ended ? "replay" : "running elsewhere: following its files"}`);
  clearTimeout(following);
  const waiting = ended && waitFor > 0 ? waitFor - 1 : 0;
  if (!ended || waiting) following = setTimeout(() => { if (state.runId === id && !state.live) openRun(id, true, waiting); }, 2000);
}

function checkpointAt(t) {  // the last checkpoint taken at or before t on the vehicle's clock
  let best = null;
  for (const c of state.checkpoints || []) if (c.sim_t != null && c.sim_t <= t + 1e-6) best = c;
  return best;
}

function replayAt(run, t) {
  const upto = run.telemetry.filter((s) => s.time_s <= t + 1e-6);
  const s = upto[upto.length - 1] || run.telemetry[0];
  layers.trail.setLatLngs(upto.map((p) => [p.lat_deg, p.lon_deg]));
  state.lastSample = s;
  showVehicle(s); showTelemetry(s);
  document.getElementById("timeline").replaceChildren();
  state.events = []; state.casualty = null;
  for (const e of run.events) if (e.sim_t == null || e.sim_t <= t + 1e-6) addEvent(e);
  drawWorld(worldAt(t));
  document.getElementById("clock").textContent = `${num(t, 1)} s`;
  const c = checkpointAt(t), fork = document.getElementById("fork-run");
  state.forkAt = c;
  fork.disabled = !c;
  fork.textContent = c ? `Fork from here (step ${c.step}, ${num(c.sim_t, 1)} s)` : "Fork from here";
}

async function relaunch(action, body) {
  const answer = await post(`/api/runs/${encodeURIComponent(state.runId)}/${action}`, body);
  if (!answer.ok) return;
  const select = document.getElementById("runs");
  if (![...select.options].some((o) => o.value === answer.run_id)) select.add(new Option(`${answer.run_id} · running`, answer.run_id), 1);
  select.value = answer.run_id;
  openRun(answer.run_id, false, 15);
}
document.getElementById("resume-run").addEventListener("click", () => relaunch("resume", {}));
document.getElementById("fork-run").addEventListener("click", () => { if (state.forkAt) relaunch("fork", { checkpoint: state.forkAt.id }); });

// ---- campaigns (each in its own process: their progress.json, re-read every 2 s) ----
function clockText(s) {
  if (typeof s !== "number") return "?";
  const t = Math.round(s), h = Math.floor(t / 3600), m = Math.floor((t % 3600) / 60), sec = t % 60;
  return `${h}:${String(m).padStart(2, "0")}:${String(sec).padStart(2, "0")}`;
}
function campaignNode(c) {
  const node = el("div", "campaign " + (c.state || "error"));
  node.dataset.campaign = c.campaign;
  if (c.error) { node.append(el("b", "", c.campaign), el("div", "why", c.error)); return node; }
  const head = el("div", "");
  head.append(el("b", "", c.campaign), el("span", "", ` · ${c.state} · ${c.done}/${c.total} records` +
    `${c.failed ? ", " + c.failed + " failed" : ""} · ${num(c.rate_per_s, 2)}/s · ETA ${c.state === "running" ? clockText(c.eta_s) : "–"}`));
  const bar = el("div", "bar"), fill = el("div", "fill");
  fill.style.width = `${c.total ? (100 * c.done) / c.total : 100}%`;
  bar.append(fill);
  const per = Object.entries(c.systems || {}).map(([name, v]) => `${name} ${v.done}${v.failed ? " (" + v.failed + " failed)" : ""}, ${num(v.rate_per_s, 2)}/s`);
  node.append(head, bar, el("div", "why", per.join(" · ")));
  return node;
}
async function pollCampaigns() {
  try {
    const { campaigns } = await api("/api/campaigns");
    state.campaigns = campaigns;
    const box = document.getElementById("campaigns");
    box.replaceChildren(...campaigns.map(campaignNode));
    box.hidden = campaigns.length === 0;
  } catch (err) { /* the next poll tries again */ }
  setTimeout(pollCampaigns, 2000);
}

async function start() {
  let listing = { runs: [], live: false };
  try { listing = await api("/api/runs"); } catch (err) { setStatus("no access: open the address with its #token"); return; }
  const select = document.getElementById("runs");
  if (listing.live) select.append(new Option("live run", "__live__"));
  const swarms = new Set(listing.runs.filter((r) => r.kind === "swarm").map((r) => r.id));  // swarm.js opens those
  const open = (id) => (swarms.has(id) ? openSwarm(id, false) : openRun(id, false));
  for (const r of listing.runs) select.append(new Option(r.kind === "swarm" ? `${r.id} · swarm of ${r.vehicles} · ` +
    `${r.outcome}${r.error ? " (" + r.error + ")" : ""}` : `${r.id} · ${r.outcome}`, r.id));
  select.addEventListener("change", () => (select.value === "__live__" ? location.reload() : open(select.value)));
  pollCampaigns();
  if (listing.live) live();
  else if (listing.runs.length) open(listing.runs[0].id);
  else setStatus("no runs yet");
}
start();
