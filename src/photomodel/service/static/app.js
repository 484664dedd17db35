// The operator page: polls the service's JSON and draws the library, results and latency;
// the live view shows camera 1 a few times a second, tracking the chosen model over /track.
"use strict";

const $ = (id) => document.getElementById(id);
let shownResults = "";
let shownModels = "";
let serviceStatus = "connecting";
let hasCamera = null;          // unknown until /health answers
let liveSocket = null;         // the /track?source=camera stream of the chosen model
let liveModel = "";
let liveTimer = null;
const LIVE_PERIOD_MS = 250;    // about four pictures a second
let session = { role: "admin", csrf: null };   // GET /session: who this is

async function loadSession() {
  try {
    session = await getJSON("session");
  } catch (error) { return; }
  $("who").textContent = session.user ? `${session.user} (${session.role})` : "";
  $("logout").hidden = !session.csrf;
  $("register-section").hidden = session.role !== "admin";
}

function changing(method, body) {
  // a browser session's changes carry its CSRF token (the service refuses them without)
  const headers = session.csrf ? { "X-CSRF-Token": session.csrf } : {};
  return { method, body, headers };
}

async function getJSON(url) {
  const response = await fetch(url, { cache: "no-store" });
  const body = await response.json();
  if (!response.ok) throw new Error(body.error || response.statusText);
  return body;
}

function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attrs)) {
    if (key === "class") node.className = value; else node.setAttribute(key, value);
  }
  for (const child of children) node.append(child);
  return node;
}

function fmt(value, digits = 2) {
  return value === null || value === undefined ? "-" : Number(value).toFixed(digits);
}

async function refreshHealth() {
  try {
    const health = await getJSON("health");
    serviceStatus = health.status;
    updateLive(health.source !== null && health.source !== undefined);
    $("status").textContent = health.status;
    $("status").className = "badge " + health.status;
    $("detail").textContent = `${health.detail} · ${health.models} models ` +
      `(${health.prepared} of at most ${health.prepared_max} prepared) · ` +
      `${health.searches} searches at once · photomodel ${health.version}`;
    $("warning").hidden = !health.warning;
    $("warning").textContent = health.warning ? `Warning: ${health.warning}` : "";
  } catch (error) {
    serviceStatus = "unreachable";
    $("status").textContent = "unreachable";
    $("status").className = "badge down";
    $("detail").textContent = "no answer from the service (retrying every 2 s)";
  }
}

async function refreshLibrary() {
  const models = await getJSON("models");
  const key = JSON.stringify(models.map((m) => [m.name, m.added_utc]));
  $("model-count").textContent = `(${models.length})`;
  $("library-empty").hidden = models.length > 0;
  $("library-empty").textContent = serviceStatus === "ok"
    ? "No models yet: register a garment below."
    : "The library's models show once the service has warmed up.";
  if (key === shownModels) return;
  shownModels = key;
  const pick = $("live-model");
  const chosen = pick.value;
  pick.replaceChildren(el("option", { value: "" }, "no model (camera only)"),
    ...models.map((m) => el("option", { value: m.name }, m.name)));
  pick.value = models.some((m) => m.name === chosen) ? chosen : "";
  const cards = models.map((m) => {
    const remove = el("button", { class: "danger", type: "button" }, "Delete");
    remove.addEventListener("click", () => deleteModel(m.name));
    remove.hidden = session.role !== "admin";
    return el("div", { class: "card", "data-model": m.name },
      el("img", { src: `${m.preview}?t=${encodeURIComponent(m.added_utc)}`, alt: m.name,
                  loading: "lazy" }),
      el("div", { class: "name" }, m.name),
      el("div", { class: "muted" },
         `${fmt(m.size_mm[0], 0)} x ${fmt(m.size_mm[1], 0)} mm · ${fmt(m.area_mm2 / 100, 0)} cm²`),
      el("div", { class: "colours" }, ...m.colours.map(swatch)),
      remove);
  });
  $("library").replaceChildren(...cards);
}

function swatch([colour, share]) {
  const chip = el("span", { class: "swatch", title: `${colour}: ${fmt(share * 100, 0)} %` });
  chip.style.backgroundColor = colour;   // an invalid value is ignored, never parsed as CSS
  return chip;
}

async function deleteModel(name) {
  if (!confirm(`Delete model ${name} from the library?`)) return;
  const response = await fetch(`models/${encodeURIComponent(name)}`, changing("DELETE"));
  if (!response.ok) alert((await response.json()).error);
  await refreshLibrary();
}

async function refreshResults() {
  const results = await getJSON("results");
  $("results-empty").hidden = results.length > 0;
  const key = results.map((r) => r.id).join(",");
  if (key === shownResults) return;
  shownResults = key;
  $("results").replaceChildren(...results.map((r) => {
    const name = r.model || (r.best_candidate ? `(${r.best_candidate})` : "no model");
    return el("div", { class: "result", "data-result": r.id },
      el("a", { href: r.overlay, target: "_blank" },
         el("img", { src: r.overlay, alt: `overlay of ${r.id}`, loading: "lazy" })),
      el("div", {},
         el("span", { class: r.found ? "found" : "missed" }, r.found ? "found" : "not found"),
         ` ${r.kind} · ${name} · score ${fmt(r.score)} · ${fmt(r.seconds * 1000, 0)} ms`),
      el("div", { class: "muted" }, r.time_utc));
  }));
}

function drawLatency(latency) {
  const svg = $("latency");
  const recent = latency.recent.slice().reverse();
  $("latency-summary").textContent = latency.count
    ? `last ${latency.count} request${latency.count === 1 ? "" : "s"}: p50 ${fmt(latency.p50_ms, 0)} ms, p99 ${fmt(latency.p99_ms, 0)} ms`
    : "(no requests yet)";
  const width = svg.clientWidth || 600;
  const height = 120;
  const top = Math.max(50, ...recent.map((r) => r.ms));
  const step = width / 100;
  const bars = recent.map((r, i) => {
    const h = Math.max(1, (r.ms / top) * (height - 16));
    const colour = r.status >= 400 ? "#b91c1c" : "#1d4ed8";
    return `<rect x="${i * step}" y="${height - h}" width="${Math.max(1, step - 1)}" ` +
      `height="${h}" fill="${colour}"><title>${r.endpoint} ${r.status}: ${r.ms} ms</title></rect>`;
  });
  svg.innerHTML = `<text x="4" y="12" font-size="11" fill="#6b7280">${fmt(top, 0)} ms</text>` +
    bars.join("");
}

async function refreshLatency() {
  const stats = await getJSON("stats");
  drawLatency(stats.latency);
}

// --- the live view ----------------------------------------------------------------------------

function updateLive(camera) {
  if (camera === hasCamera) return;
  hasCamera = camera;
  $("live-none").hidden = camera;
  $("live").hidden = !camera;
  $("live-model").disabled = !camera;
  if (camera) {
    $("live-status").textContent = "camera 1";
    openLiveStream();
    if (liveTimer === null) nextPicture();
  } else {
    $("live-status").textContent = "no camera";
    closeLiveStream();
  }
}

function nextPicture() {
  liveTimer = null;
  if (!hasCamera) return;
  const query = liveModel ? `?model=${encodeURIComponent(liveModel)}&overlay=1&` : "?";
  $("live").src = `camera/latest.jpg${query}t=${Date.now()}`;
}

$("live").addEventListener("load", () => {
  liveTimer = setTimeout(nextPicture, LIVE_PERIOD_MS);
});
$("live").addEventListener("error", () => {     // the source is down: try again later
  $("live-status").textContent = "camera 1: no picture (retrying)";
  liveTimer = setTimeout(nextPicture, 2000);
});

function closeLiveStream() {
  if (liveSocket !== null) liveSocket.close();
  liveSocket = null;
}

function openLiveStream() {
  closeLiveStream();
  liveModel = $("live-model").value;
  if (!liveModel || !hasCamera) return;
  const url = new URL(`track?model=${encodeURIComponent(liveModel)}&source=camera&credit=1`,
                      location.href);
  url.protocol = url.protocol === "https:" ? "wss:" : "ws:";
  const socket = new WebSocket(url);
  liveSocket = socket;
  socket.addEventListener("message", (event) => {
    if (socket !== liveSocket) return;
    const answer = JSON.parse(event.data);
    $("live-status").textContent = answer.error
      ? `camera 1 · ${answer.error}`
      : `camera 1 · ${liveModel}: ${answer.mode} · score ${fmt(answer.score)} · frame ${answer.frame_index}`;
    // one answer at a time, about as often as a picture is shown
    setTimeout(() => { if (socket.readyState === WebSocket.OPEN) socket.send('{"credit": 1}'); },
               LIVE_PERIOD_MS);
  });
  socket.addEventListener("close", () => {
    if (socket === liveSocket) {
      liveSocket = null;
      setTimeout(() => { if (liveSocket === null && hasCamera) openLiveStream(); }, 2000);
    }
  });
}

$("live-model").addEventListener("change", openLiveStream);

$("register").addEventListener("submit", async (event) => {
  event.preventDefault();
  const form = event.target;
  const status = $("register-status");
  const button = form.querySelector("button");
  button.disabled = true;
  status.className = "muted";
  status.textContent = "building the photo-model ...";
  try {
    const data = new FormData(form);
    if (!data.get("distance_mm")) data.delete("distance_mm");
    const response = await fetch("models", changing("POST", data));
    const body = await response.json();
    if (!response.ok) throw new Error(body.error || response.statusText);
    status.textContent = `registered ${body.name}: ${fmt(body.size_mm[0], 0)} x ` +
      `${fmt(body.size_mm[1], 0)} mm`;
    form.reset();
    await refreshLibrary();
  } catch (error) {
    status.className = "error";
    status.textContent = error.message;
  } finally {
    button.disabled = false;
  }
});

async function refresh() {
  await refreshHealth();
  for (const step of [refreshLibrary, refreshResults, refreshLatency]) {
    try { await step(); } catch (error) { /* warming up or unreachable: shown in the badge */ }
  }
}

loadSession().then(refresh);
setInterval(refresh, 2000);
