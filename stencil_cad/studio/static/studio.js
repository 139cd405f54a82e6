// The studio page: settings -> previews streamed as they improve; Make -> progress, zip, sheet.
"use strict";
const $ = (id) => document.getElementById(id);
const state = { image: null, preview: null, job: null, timer: null };

function settings() {
  const chosen = [...document.querySelectorAll("#cans input:checked")].map((c) => c.value);
  const paintMode = document.querySelector("input[name=paint_mode]:checked").value;
  const fixed = $("standoff_mode").value === "fixed";
  return {
    image: state.image,
    width_mm: Number($("width_mm").value),
    process: $("process").value,
    bed: $("bed").value,
    layers: Number($("layers").value),
    paints: paintMode === "auto" || chosen.length === 0 ? "auto" : chosen,
    distance_m: Number($("distance_m").value),
    standoff_mm: fixed ? Number($("standoff_mm").value) : null,
    profile: [...$("profile").selectedOptions].map((o) => o.value),
    crop: cropping(),
  };
}

// The crop in % of the picture, [x, y, width, height]; null for the whole picture.
function cropping() {
  const c = ["crop_x", "crop_y", "crop_w", "crop_h"].map((id) => Number($(id).value));
  return c[0] === 0 && c[1] === 0 && c[2] === 100 && c[3] === 100 ? null : c;
}

function drawCrop() {
  const [x, y, w, h] = ["crop_x", "crop_y", "crop_w", "crop_h"].map((id) => Number($(id).value));
  Object.assign($("crop-box").style, { left: `${x}%`, top: `${y}%`, width: `${w}%`, height: `${h}%` });
}

function setCrop(c) {
  ["crop_x", "crop_y", "crop_w", "crop_h"].forEach((id, i) => { $(id).value = Math.round(c[i] * 2) / 2; });
  drawCrop();
}

function cropDrag() {
  // Drag a rectangle over the whole picture; the crop is sent when the pointer is let go.
  const area = $("crop-area");
  let start = null;
  const at = (e) => {
    const r = $("crop-source").getBoundingClientRect();
    return [Math.min(100, Math.max(0, (100 * (e.clientX - r.left)) / r.width)),
      Math.min(100, Math.max(0, (100 * (e.clientY - r.top)) / r.height))];
  };
  const box = (e) => {
    const p = at(e);
    return [Math.min(start[0], p[0]), Math.min(start[1], p[1]), Math.abs(p[0] - start[0]), Math.abs(p[1] - start[1])];
  };
  area.addEventListener("pointerdown", (e) => { start = at(e); area.setPointerCapture(e.pointerId); });
  area.addEventListener("pointermove", (e) => { if (start) setCrop(box(e)); });
  area.addEventListener("pointerup", (e) => {
    if (!start) return;
    const c = box(e); start = null;
    if (c[2] >= 1 && c[3] >= 1) setCrop(c); else setCrop([0, 0, 100, 100]);
    changed();
  });
}

function drawTiles(p) {
  // The mural's tiles as the job cuts them, over the picture (y of the tiles runs up from the bottom).
  const svg = $("tiles");
  svg.hidden = p.tiles < 2;
  if (svg.hidden) return;
  const [w, h] = p.size_mm;
  svg.setAttribute("viewBox", `0 0 ${w} ${h}`);
  const size = Math.max(w, h) / 40;
  svg.innerHTML = p.tiles_mm.map((t) =>
    `<rect x="${t.x0}" y="${h - t.y1}" width="${t.x1 - t.x0}" height="${t.y1 - t.y0}"></rect>` +
    `<text x="${t.x0 + size / 2}" y="${h - t.y1 + 1.5 * size}" font-size="${size}">${t.name}</text>`).join("");
}

function setStatus(text) { $("status").textContent = text; }
function showError(id, text) { const e = $(id); e.textContent = text || ""; e.hidden = !text; }

function fmt(x, d = 2) { return x === null || x === undefined ? "—" : Number(x).toFixed(d); }

function showPreview(p) {
  $("reference").src = p.reference;
  $("sprayed").src = p.sprayed;
  $("f-level").textContent = `${p.level}${p.final ? " (final)" : ", improving…"} in ${fmt(p.seconds, 1)} s`;
  $("f-scielab").textContent = `${fmt(p.scielab)} at ${p.distance_m} m`;
  $("f-scielab2").textContent = `${fmt(p.scielab_2x)} at ${2 * p.distance_m} m`;
  $("f-passes").textContent = p.passes ? p.passes.join(" · ") : "—";
  $("f-holes").textContent = p.holes ? p.holes.map((n) => n.toLocaleString()).join(" · ") : "—";
  $("f-parts").textContent = `${p.plates} plates, ${p.walls} wall(s), ${p.tiles} tile(s)`;
  // Before the plate-design trials, an automatic wall is the likeliest choice, not yet the job's.
  const likely = !p.designed && $("standoff_mode").value === "auto" ? " (likely; the job's trials come last)" : "";
  $("f-standoff").textContent = `${p.standoff_mm} mm, windows ${p.windows}` + (p.designed ? " (the job's choice)" : likely);
  if (p.scielab_range) {
    $("f-range").textContent = `between ${fmt(p.scielab_range[0])} and ${fmt(p.scielab_range[1])} depending on your can`;
  } else {
    $("f-range").textContent = p.final ? `${fmt(p.scielab)}: every layer's can is measured` : "— (on the last preview)";
  }
  const c = p.cost;
  $("f-cost").textContent = c.cut_m != null
    ? `${c.sheets} sheet(s), laser cut ${fmt(c.cut_m, 1)} m in about ${fmt(c.cut_hours, 1)} h`
    : `about ${fmt(c.printer_hours, 1)} printer-hours, ${fmt(c.filament_m, 0)} m of filament (${fmt(c.filament_g, 0)} g)`;
  // A paint's light and dark plates (stipple.light_plates) are one paint: each paint shown once.
  const paints = [...new Set(p.paints)];
  const swatches = [p.primer, ...paints].map((h) => `<span class="swatch" style="background:${h}" title="${h}"></span>`).join(" ");
  const cans = (c.paint || []).reduce((s, x) => s + x.cans, 0);
  const plates = paints.length < p.paints.length ? ` on ${p.paints.length} plates` : "";
  $("f-paint").innerHTML = `${swatches} primer + ${paints.length} paints${plates}` + (c.paint && c.paint.length ? `, ${fmt(cans, 2)} can(s) in all` : "");
  $("sprayed").dataset.level = p.level;
  paintKeys(p);
  drawTiles(p);
}

function preview() {
  // A newer change replaces the stream: the server cancels the stale preview's work.
  if (state.preview) state.preview.close();
  showError("settings-error", "");
  const url = "/api/preview?settings=" + encodeURIComponent(JSON.stringify(settings()));
  setStatus("previewing…");
  const es = new EventSource(url);
  state.preview = es;
  es.onmessage = (m) => {
    const p = JSON.parse(m.data);
    if (p.level === "error") { showError("settings-error", p.error); setStatus("ready"); es.close(); return; }
    if (p.level === "cancelled") { es.close(); return; }
    showPreview(p);
    if (p.final) { setStatus("ready"); es.close(); }
  };
  es.onerror = () => {
    es.close();
    if (state.preview !== es) return;
    // A 4xx before the stream opened: ask again to read the message.
    fetch(url).then((r) => (r.ok ? null : r.json())).then((j) => { if (j) showError("settings-error", j.error); });
    setStatus("ready");
  };
}

function changed() { clearTimeout(state.timer); state.timer = setTimeout(preview, 150); }

async function upload(file) {
  showError("upload-error", "");
  setStatus("checking the picture…");
  const r = await fetch("/api/upload?name=" + encodeURIComponent(file.name), { method: "POST", body: file });
  const j = await r.json();
  if (!r.ok) { showError("upload-error", j.error); setStatus("ready"); return; }
  state.image = j.id;
  $("crop-source").src = `/api/pictures/${j.id}`;
  setCrop([0, 0, 100, 100]);
  $("picture-name").textContent = `${j.name} (${j.width_px} × ${j.height_px} px at this size)`;
  changed();
}

async function make() {
  showError("settings-error", "");
  const r = await fetch("/api/jobs", { method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(settings()) });
  const j = await r.json();
  if (!r.ok) { showError("settings-error", j.error); return; }
  state.job = j.id;
  $("job").hidden = false; $("stages").innerHTML = ""; $("job-result").textContent = "making…";
  $("job-links").hidden = true; $("sheet-frame").hidden = true;
  $("make").disabled = true; $("cancel").hidden = false;
  const es = new EventSource(`/api/jobs/${j.id}/events`);
  es.onmessage = (m) => {
    const e = JSON.parse(m.data);
    if (e.event === "start") {
      const li = document.createElement("li"); li.id = `stage-${e.stage}`; li.textContent = `${e.stage} …`; $("stages").append(li);
    } else if (e.event === "done") {
      const li = $(`stage-${e.stage}`); if (li) li.textContent = `${e.stage} ✓`;
    } else {
      es.close(); $("make").disabled = false; $("cancel").hidden = true;
      if (e.event === "finished") {
        $("job-result").textContent = `made: S-CIELAB ${fmt(e.scielab)} at the viewing distance`;
        $("zip").href = `/api/jobs/${j.id}/files/job.zip`;
        $("sheet").href = `/api/jobs/${j.id}/files/output/instructions.html`;
        $("job-links").hidden = false;
      } else if (e.event === "cancelled") {
        $("job-result").textContent = "cancelled: nothing was kept";
      } else {
        $("job-result").textContent = `failed: ${e.message}`;
      }
    }
  };
}

async function makeCard() {
  showError("calibrate-error", "");
  setStatus("making the card…");
  const r = await fetch("/api/card", { method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(settings()) });
  const j = await r.json();
  setStatus("ready");
  if (!r.ok) { showError("calibrate-error", j.error); return; }
  state.card = j.id;
  $("card-sheet").href = `/api/cards/${j.id}/files/card_sheet.pdf`;
  $("card-sheet").hidden = false;
  $("card-passes").textContent = j.passes;
}

async function profiles(select) {
  const list = await (await fetch("/api/profiles")).json();
  const keep = new Set([...$("profile").selectedOptions].map((o) => o.value));
  if (select) {
    // A new profile replaces a chosen one measured for the same paint.
    const key = (list.find((p) => p.id === select) || {}).key;
    for (const p of list) if (p.key === key) keep.delete(p.id);
    keep.add(select);
  }
  $("profile").length = 0;
  for (const p of list) {
    const label = `${p.key === "default" ? "every layer" : p.key}: spread ${p.spread_k}, deposit ${p.deposit_per_pass}`;
    $("profile").add(new Option(label, p.id, false, keep.has(p.id)));
  }
}

function paintKeys(p) {
  // The paints the wizard can key a profile to: this preview's layers by hex, the can list by name.
  const opts = [...new Set(p.paints)].map((h, i) => `<option value="${h}">layer ${i + 1}</option>`);
  for (const c of state.cans || []) opts.push(`<option value="${c.name}">${c.hex}</option>`);
  $("paint-keys").innerHTML = opts.join("");
}

async function fitPhoto(file) {
  showError("calibrate-error", "");
  if (!state.card) { showError("calibrate-error", "make the card first"); return; }
  setStatus("fitting the photo…");
  const q = new URLSearchParams({ card: state.card, paint: $("paint-name").value, name: file.name });
  const r = await fetch(`/api/calibrate?${q}`, { method: "POST", body: file });
  const j = await r.json();
  setStatus("ready");
  if (!r.ok) { showError("calibrate-error", j.error); return; }
  const rows = [
    ["Markers found per wall", j.markers_found.join(" · ")],
    ["Spread k", j.spread_k], ["Bleed σ", `${j.bleed_sigma_mm} mm`], ["Deposit per pass", j.deposit_per_pass],
    ["Residual RMS", `${j.residual_rms} (photo noise ${j.noise})`],
    ["By feature", Object.entries(j.feature_residuals).map(([k, v]) => `${k} ${v}`).join(", ")],
  ];
  $("fit").innerHTML = rows.map(([k, v]) => `<tr><th>${k}</th><td>${v}</td></tr>`).join("");
  $("fit").hidden = false;
  await profiles(j.id);
  changed();
}

async function cancel() {
  if (state.job) await fetch(`/api/jobs/${state.job}/cancel`, { method: "POST" });
}

async function init() {
  const o = await (await fetch("/api/options")).json();
  for (const p of o.processes) $("process").add(new Option(p, p, p === o.defaults.process, p === o.defaults.process));
  for (const b of o.beds) $("bed").add(new Option(b, b));
  state.cans = o.cans;
  $("cans").innerHTML = o.cans.map((c) =>
    `<label><input type="checkbox" value="${c.hex}"><span class="swatch" style="background:${c.hex}"></span>${c.name} (${c.code})</label>`).join("");
  for (const el of document.querySelectorAll("#settings input, #settings select")) {
    if (!["file", "photo", "paint-name"].includes(el.id)) el.addEventListener("change", changed);
  }
  document.querySelectorAll("input[name=paint_mode]").forEach((r) => r.addEventListener("change", () => {
    $("cans").hidden = document.querySelector("input[name=paint_mode]:checked").value === "auto";
  }));
  $("standoff_mode").addEventListener("change", () => { $("standoff_mm").disabled = $("standoff_mode").value !== "fixed"; });
  $("file").addEventListener("change", () => { if ($("file").files.length) upload($("file").files[0]); });
  const drop = $("drop");
  drop.addEventListener("dragover", (e) => { e.preventDefault(); drop.classList.add("over"); });
  drop.addEventListener("dragleave", () => drop.classList.remove("over"));
  drop.addEventListener("drop", (e) => { e.preventDefault(); drop.classList.remove("over"); if (e.dataTransfer.files.length) upload(e.dataTransfer.files[0]); });
  $("slider").addEventListener("input", () => $("compare").style.setProperty("--cut", `${$("slider").value}%`));
  $("zoom").addEventListener("input", () => $("compare").style.setProperty("--zoom", $("zoom").value));
  $("crop-source").src = "/api/pictures/example";
  drawCrop();
  cropDrag();
  for (const id of ["crop_x", "crop_y", "crop_w", "crop_h"]) $(id).addEventListener("input", drawCrop);
  $("crop-none").addEventListener("click", () => { setCrop([0, 0, 100, 100]); changed(); });
  $("make").addEventListener("click", make);
  $("make-card").addEventListener("click", makeCard);
  $("photo").addEventListener("change", () => { if ($("photo").files.length) fitPhoto($("photo").files[0]); });
  await profiles();
  $("cancel").addEventListener("click", cancel);
  $("sheet").addEventListener("click", () => { $("sheet-frame").hidden = false; });
  preview();
}
init();
