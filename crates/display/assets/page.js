"use strict";
// Everything here is drawn from the snapshots of /events (server-sent events); nothing is
// fetched from anywhere else. The page shows what the newest snapshot holds and nothing
// more: a vessel the display no longer keeps loses its card, and once snapshots stop coming
// (the display stopped, the network dropped) every card is shown stale with nothing drawn,
// never as its last forecast or decision.
const SVG = "http://www.w3.org/2000/svg";
const W = 300, H = 130, PAD = 22;

function el(tag, attrs, parent) {
  const e = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (parent) parent.appendChild(e);
  return e;
}

// One chart: the mean with its +-2 sigma band over lead time, and the limit lines if any.
function drawChart(svg, track, dt, limit, unit) {
  while (svg.firstChild) svg.removeChild(svg.firstChild);
  svg.setAttribute("viewBox", `0 0 ${W} ${H}`);
  const n = track.mean.length;
  if (n === 0) return;
  let span = limit || 0;
  for (let k = 0; k < n; k++) span = Math.max(span, Math.abs(track.mean[k]) + 2 * track.sigma[k]);
  span = span > 0 ? span * 1.1 : 1;
  const x = k => PAD + (W - PAD - 4) * (k + 1) / n;
  const y = v => H / 2 - (H / 2 - 8) * v / span;
  const upper = [], lower = [], mean = [];
  for (let k = 0; k < n; k++) {
    upper.push(`${x(k)},${y(track.mean[k] + 2 * track.sigma[k])}`);
    lower.unshift(`${x(k)},${y(track.mean[k] - 2 * track.sigma[k])}`);
    mean.push(`${x(k)},${y(track.mean[k])}`);
  }
  el("line", { x1: PAD, x2: W - 4, y1: y(0), y2: y(0), stroke: "#33404d" }, svg);
  el("polygon", { points: upper.concat(lower).join(" "), fill: "var(--band)" }, svg);
  el("polyline", { points: mean.join(" "), fill: "none", stroke: "var(--mean)", "stroke-width": 2 }, svg);
  if (limit) {
    for (const l of [limit, -limit]) {
      el("line", { x1: PAD, x2: W - 4, y1: y(l), y2: y(l), stroke: "var(--limit)",
                   "stroke-dasharray": "4 3" }, svg);
    }
  }
  const label = (text, lx, ly, anchor) => {
    const t = el("text", { x: lx, y: ly, fill: "#8b9bab", "font-size": 10, "text-anchor": anchor }, svg);
    t.textContent = text;
  };
  label(`+${span.toFixed(span < 10 ? 1 : 0)} ${unit}`, 2, 12, "start");
  label(`${(n * dt).toFixed(0)} s`, W - 4, H - 3, "end");
  label("0 s", PAD, H - 3, "start");
}

function card(v) {
  let c = document.querySelector(`.vessel[data-vessel="${CSS.escape(v.vessel)}"]`);
  if (c) return c;
  c = document.createElement("div");
  c.className = "vessel";
  c.dataset.vessel = v.vessel;
  c.innerHTML = `<h2><span class="name"></span><span class="status"></span><span class="meta"></span></h2>
    <div class="charts">
      <div class="chart"><div class="title">heave [m] mean &plusmn;2&sigma;</div><svg data-dof="heave"></svg></div>
      <div class="chart"><div class="title">roll [deg] and limit</div><svg data-dof="roll"></svg></div>
      <div class="chart"><div class="title">pitch [deg] and limit</div><svg data-dof="pitch"></svg></div>
    </div>
    <div class="advisory"></div><div class="skill"></div>`;
  c.querySelector(".name").textContent = v.vessel;
  document.getElementById("vessels").appendChild(c);
  return c;
}

// Withdraw what a card shows: its charts, advisories and skill.
function withdraw(c) {
  for (const svg of c.querySelectorAll("svg")) {
    while (svg.firstChild) svg.removeChild(svg.firstChild);
  }
  c.dataset.seq = "";
  c.querySelector(".advisory").textContent = "";
  c.querySelector(".skill").textContent = "";
}

function fmt(x, digits) { return x === null || x === undefined ? "-" : x.toFixed(digits); }

function render(s) {
  document.getElementById("empty").style.display = s.vessels.length ? "none" : "block";
  const shown = new Set(s.vessels.map(v => v.vessel));
  for (const c of document.querySelectorAll(".vessel")) {
    if (!shown.has(c.dataset.vessel)) c.remove();
  }
  for (const v of s.vessels) {
    const c = card(v);
    c.classList.toggle("stale", v.stale);
    const f = v.forecast;
    c.querySelector(".status").textContent = v.stale
      ? (v.age_s === null ? "no forecast yet" : `STALE ${fmt(v.age_s, 0)} s`) : "live";
    c.querySelector(".meta").textContent = f
      ? `seq ${f.seq}  t=${f.time_s.toFixed(1)} s  model v${f.model_version}  rejected ${v.rejected}`
      : `rejected ${v.rejected}`;
    if (!f) withdraw(c);
    c.dataset.seq = f ? f.seq : "";
    if (f) {
      drawChart(c.querySelector('svg[data-dof="heave"]'), f.heave, f.dt_s, 0, "m");
      drawChart(c.querySelector('svg[data-dof="roll"]'), f.roll, f.dt_s, s.limits.roll_deg, "deg");
      drawChart(c.querySelector('svg[data-dof="pitch"]'), f.pitch, f.dt_s, s.limits.pitch_deg, "deg");
    }
    const adv = c.querySelector(".advisory");
    adv.textContent = "";
    for (const [station, a] of Object.entries(v.advisories)) {
      // The station's own decision: go when the probability that every limit holds over the
      // whole minimum operation time (MOT) reaches its go threshold. Only a go is green.
      const d = a.decision;
      const line = document.createElement("div");
      const verdict = document.createElement("b");
      if (a.stale_s !== null && a.stale_s !== undefined) {
        // The station stopped publishing: its last decision is not shown as current.
        verdict.className = "nogo";
        verdict.textContent = `STALE (no advisory for ${fmt(a.stale_s, 0)} s)`;
        line.append(`${station}: `, verdict);
        adv.appendChild(line);
        continue;
      }
      // Green only for a go with its probability (the display refuses any other go).
      const go = d.go && d.probability_now !== null;
      verdict.className = go ? "go" : "nogo";
      verdict.textContent = d.probability_now === null
        ? (d.frozen_dof
          ? `NO-GO (the ${d.frozen_ship ? `${d.frozen_ship} vessel's ` : ""}${d.frozen_dof} sensor repeats its value; MOT ${fmt(d.mot_s, 0)} s)`
          : d.awaiting_verified_errors
          ? `NO-GO (no probability until forecasts are verified; MOT ${fmt(d.mot_s, 0)} s)`
          : `NO-GO (MOT ${fmt(d.mot_s, 0)} s beyond the horizon)`)
        : `${go ? "GO" : "NO-GO"} ${fmt(100 * d.probability_now, 0)} % over ${fmt(d.mot_s, 0)} s`;
      const next = go ? "" : d.next_window_s !== null && d.next_window_s !== undefined
        ? ` · next go window in ${fmt(d.next_window_s, 1)} s (${fmt(100 * d.next_window_probability, 0)} %)`
        : " · no go window within the horizon";
      const exceed = d.next_exceedance_s === null
        ? " · no exceedance predicted" : ` · exceedance in ${fmt(d.next_exceedance_s, 1)} s`;
      const maxima = a.max_roll_deg === null || a.max_roll_deg === undefined ? ""
        : ` · max roll ${fmt(a.max_roll_deg, 1)} deg, pitch ${fmt(a.max_pitch_deg, 1)} deg`;
      line.append(`${station}: `, verdict, next, exceed, maxima);
      adv.appendChild(line);
    }
    c.querySelector(".skill").textContent = v.skill.length
      ? "live skill (NRMSE vs zero at 5/10/20 s): " + v.skill.map(d =>
          `${d.dof} ${d.nrmse_at.map(x => fmt(x, 2)).join("/")}`).join("   ")
      : "live skill: not yet scored";
  }
}

// No snapshot for this long (they come twice a second): what the page shows is not current.
const SILENCE_MS = 3000;
let lastSnapshot = null;

// The display cannot be heard: every card is stale, with nothing drawn on it.
function lost(why) {
  document.getElementById("connection").textContent = why;
  for (const c of document.querySelectorAll(".vessel")) {
    c.classList.add("stale");
    c.querySelector(".status").textContent = "STALE (display not heard)";
    withdraw(c);
  }
}

const events = new EventSource("/events");
events.onopen = () => { document.getElementById("connection").textContent = "connected"; };
events.onerror = () => lost("reconnecting...");
events.onmessage = (e) => {
  // performance.now(): a monotonic clock, which a wall-clock step (NTP, a bridge PC's clock
  // set by hand) cannot move; Date.now() could make a live page look silent, or hide silence.
  lastSnapshot = performance.now();
  document.getElementById("connection").textContent = `connected, updated ${new Date().toLocaleTimeString()}`;
  render(JSON.parse(e.data));
};
setInterval(() => {
  const silent = lastSnapshot === null ? 0 : performance.now() - lastSnapshot;
  if (silent > SILENCE_MS) {
    lost(`no snapshot for ${(silent / 1000).toFixed(0)} s, waiting...`);
  }
}, 1000);
