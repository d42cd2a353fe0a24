// A swarm run in the console: every UAV on one map (its trail and position, a colour and its label), the sectors
// and who was awarded each, the casualties; one timeline of every UAV's events and the swarm's, each tagged with
// its UAV; the time slider moves every vehicle. Loaded before console.js: it only defines functions, which use
// console.js's map, state and helpers when they are called.
"use strict";

const UAV_COLOURS = ["#d81b60", "#1e88e5", "#43a047", "#fb8c00", "#8e24aa", "#00897b", "#6d4c41", "#3949ab"];
let swarmView = null;  // { layer, trails: {uav: polyline}, markers: {uav: marker}, colour: {uav: colour} }

function uavColour(uav) {
  return (swarmView && swarmView.colour[uav]) || "#37474f";
}

function uavIcon(uav, yaw) {  // an arrow in the UAV's colour, its label beside it (text only, never HTML from files)
  const html = document.createElement("div");
  html.className = "uav-marker";
  html.innerHTML = `<svg width="22" height="22" viewBox="-11 -11 22 22"><g transform="rotate(${Number(yaw) || 0})">` +
    `<path d="M0,-10 L7,8 L0,4 L-7,8 Z" stroke="#fff" stroke-width="1.5"/></g></svg>`;
  html.querySelector("path").setAttribute("fill", uavColour(uav));
  html.append(el("span", "uav-label", uav));
  return L.divIcon({ className: "uav", iconSize: [22, 22], iconAnchor: [11, 11], html });
}

function uavTag(uav) {
  const tag = el("span", "uav-tag", uav);
  tag.style.background = uav === "swarm" ? "#546e7a" : uavColour(uav);
  return tag;
}

function leaveSwarm() {  // opening a single run: the swarm's layers go
  if (swarmView) { swarmView.layer.remove(); swarmView = null; }
  state.swarm = null;
  const legend = document.getElementById("swarm");
  legend.replaceChildren();
  legend.hidden = true;
}

function drawSwarm(run) {
  if (swarmView) swarmView.layer.remove();
  if (vehicle) { vehicle.remove(); vehicle = null; }  // console.js's one vehicle: a swarm has many
  layers.trail.setLatLngs([]);
  drawWorld(null);
  const layer = L.layerGroup().addTo(map), colour = {}, trails = {}, markers = {};
  run.vehicles.forEach((v, i) => { colour[v.uav] = UAV_COLOURS[i % UAV_COLOURS.length]; });
  swarmView = { layer, trails, markers, colour };
  const bounds = [];
  for (const s of run.sectors) {
    if (s.polygon.length < 3) continue;
    bounds.push(...s.polygon);
    L.polygon(s.polygon, { color: uavColour(s.awarded), weight: 2, fillOpacity: 0.08 }).bindTooltip(tip(
      `sector ${s.id}: awarded to ${s.awarded || "nobody"}; surveyed by ${s.surveyed_by.join(", ") || "nobody yet"}`))
      .addTo(layer);
  }
  for (const c of run.casualties) {
    if (!c.at) continue;
    L.circleMarker(c.at, { radius: 7, color: "#b3261e", weight: 3, fillOpacity: 0.3 }).bindTooltip(tip(
      `casualty ${c.id}: found by ${c.found_by}, seen by ${c.verified_by.join(", ") || "nobody else"}` +
      `${c.verified ? " (verified)" : ""}; kit to ${c.delivery_awarded || "nobody yet"}` +
      `${c.delivered ? ", delivered" : ""}`), { permanent: true, direction: "right" }).addTo(layer);
  }
  for (const v of run.vehicles) {
    trails[v.uav] = L.polyline([], { color: colour[v.uav], weight: 2 }).addTo(layer);
    const first = v.telemetry[0];
    if (first) {
      markers[v.uav] = L.marker([first.lat_deg, first.lon_deg], { icon: uavIcon(v.uav, first.yaw_deg),
        zIndexOffset: 1000 }).bindTooltip(tip(`${v.uav} (${v.role || "no role"}): ${v.outcome}`)).addTo(layer);
      bounds.push([first.lat_deg, first.lon_deg]);
    }
  }
  if (bounds.length) map.fitBounds(L.latLngBounds(bounds).pad(0.3), { animate: false });
}

function drawLegend(run) {  // one chip per UAV: a click shows its telemetry in the strip
  const legend = document.getElementById("swarm");
  legend.hidden = false;
  legend.replaceChildren();
  for (const v of run.vehicles) {
    const chip = el("button", "uav-chip" + (state.swarmUav === v.uav ? " chosen" : ""));
    chip.dataset.uav = v.uav;
    chip.append(uavTag(v.uav), el("span", "", ` ${v.role || ""} · ${v.outcome}`));
    chip.addEventListener("click", () => { state.swarmUav = v.uav; drawLegend(run); swarmAt(run, state.swarmT); });
    legend.append(chip);
  }
  const sep = run.summary && run.summary.separation;
  if (sep) legend.append(el("div", "why", `closest ${num(sep.min_distance_m, 1)} m (${(sep.closest || []).join(", ")}` +
    ` at ${num(sep.at_s, 1)} s); losses ${sep.losses}`));
  for (const p of run.problems) legend.append(el("div", "why warn", p));
}

function swarmAt(run, t) {
  state.swarmT = t;
  for (const v of run.vehicles) {
    const upto = v.telemetry.filter((s) => s.time_s <= t + 1e-6);
    swarmView.trails[v.uav].setLatLngs(upto.map((s) => [s.lat_deg, s.lon_deg]));
    const s = upto[upto.length - 1] || v.telemetry[0];
    const marker = swarmView.markers[v.uav];
    if (s && marker) { marker.setLatLng([s.lat_deg, s.lon_deg]); marker.setIcon(uavIcon(v.uav, s.yaw_deg)); }
    state.swarmSamples[v.uav] = s || null;
    if (v.uav === state.swarmUav) { state.lastSample = s; showTelemetry(s); }
  }
  const list = document.getElementById("timeline");
  list.replaceChildren();
  state.events = [];
  for (const e of run.events) {
    if (e.sim_t != null && e.sim_t > t + 1e-6) continue;
    state.events.push(e);
    if (!SHOWN.has(e.kind) && e.kind !== "swarm") continue;
    const node = eventNode(e);
    node.dataset.uav = e.uav;
    node.prepend(uavTag(e.uav));
    list.prepend(node);
    if (list.childElementCount > 800) list.lastChild.remove();
  }
  document.getElementById("clock").textContent = `${num(t, 1)} s`;
}

async function openSwarm(id, keepView) {  // a swarm still flying in another process is re-read every 2 s
  const run = await api(`/api/swarms/${encodeURIComponent(id)}`);
  const slider = document.getElementById("slider");
  const atEnd = !keepView || Number(slider.value) >= Number(slider.max) - Number(slider.step);
  state.live = false; state.runId = id; state.swarm = run; state.casualty = null; state.worlds = [];
  state.swarmSamples = {};
  if (!run.vehicles.some((v) => v.uav === state.swarmUav)) state.swarmUav = run.vehicles.length ? run.vehicles[0].uav : null;
  document.getElementById("controls").hidden = true;
  document.getElementById("approvals").replaceChildren();
  document.getElementById("resume-run").hidden = true;
  document.getElementById("fork-run").hidden = true;
  if (!keepView) { drawScene(run.scene); drawMission(run.mission, run.scene && run.scene.home); }
  drawSwarm(run);
  drawLegend(run);
  const times = run.vehicles.flatMap((v) => v.telemetry.map((s) => s.time_s));
  slider.min = times.length ? Math.min(...times) : 0;
  slider.max = times.length ? Math.max(...times) : 0;
  if (atEnd) slider.value = slider.max;
  document.getElementById("replay").hidden = false;
  slider.oninput = () => swarmAt(run, Number(slider.value));
  swarmAt(run, Number(slider.value));
  const running = run.outcome === "running";
  setStatus(`${id}: swarm of ${run.vehicles.length}, ${running ? "running elsewhere: following its files" : run.outcome}`);
  clearTimeout(following);
  if (running) following = setTimeout(() => { if (state.runId === id && state.swarm) openSwarm(id, true); }, 2000);
}
