// The viewer page: a scene's Gaussians coloured by entity, labels, the graph's edges, an
// entity inspector, and an ask box whose answer is highlighted in 3D.
//
// State the page exposes on <body> (for scripts and tests):
//   data-ready        "1" once the current scene has been drawn, "0" while loading
//   data-scene        the scene shown
//   data-splats       how many Gaussians are drawn
//   data-ask          "idle", "pending", "done" or "error"
//   data-highlighted  the answer's entity ids, space separated
//   data-selected     the inspected entity id ("" for none)
// The page opens the scene named by "#scene=ID" in its URL (or ?scene=ID), else the first;
// "&max=N" in the fragment asks for at most N Gaussians (the server's default otherwise).

import { OrbitCamera } from "./camera.js";
import { Overlay, RELATION_COLORS } from "./overlay.js";
import { SplatRenderer, decodePayload } from "./splats.js";

const BACKGROUND = [0.082, 0.09, 0.11];
const STRUCTURE = new Set(["wall", "floor", "ceiling"]);
const ALWAYS_HIDDEN = new Set(["ceiling"]);
const RELATIONS_ON = new Set(["supported_by", "inside"]);

const $ = (id) => document.getElementById(id);
const body = document.body;

class ApiError extends Error {}

async function request(path, options = {}) {
  const res = await fetch(path, options);
  if (!res.ok) {
    let message = `${res.status} ${res.statusText}`;
    try {
      const doc = await res.json();
      if (doc && doc.error) message = doc.error;
    } catch (_) { /* not JSON */ }
    throw new ApiError(message);
  }
  return res;
}

const getJSON = async (path) => (await request(path)).json();
const sceneUrl = (id) => `/api/scenes/${encodeURIComponent(id)}`;

function el(tag, props = {}, ...children) {
  const node = document.createElement(tag);
  Object.assign(node, props);
  for (const c of children) node.append(c);
  return node;
}

function fmt(v) {
  return Array.isArray(v) ? v.map((x) => Number(x).toFixed(2)).join(", ") : String(v);
}

class Viewer {
  constructor() {
    this.glCanvas = $("gl");
    this.overlayCanvas = $("overlay");
    this.renderer = new SplatRenderer(this.glCanvas);
    this.overlay = new Overlay(this.overlayCanvas, $("labels"), (id) => this.select(id),
      (id) => this.focus(id));
    this.camera = new OrbitCamera("z");
    this.scene = null;
    this.entities = [];
    this.byId = new Map();
    this.slotOf = new Map();
    this.palette = {};
    this.highlightColor = "#ff00ff";
    this.highlighted = new Set();
    this.selected = null;
    this.relationsOn = new Set(RELATIONS_ON);
    this.showWalls = true;
    this.frameRequested = false;
    this.loadToken = 0;
    this.bindUi();
    new ResizeObserver(() => this.resize()).observe($("stage"));
    this.resize();
  }

  // ---- loading --------------------------------------------------------------------------

  async start() {
    try {
      const { scenes } = await getJSON("/api/scenes");
      const picker = $("scene-picker");
      picker.replaceChildren(...scenes.map((s) => el("option", {
        value: s.scene_id, textContent: `${s.scene_id} (${s.entities} entities)`,
      })));
      if (scenes.length === 0) {
        this.status("the store has no scenes: build or ingest one first");
        body.dataset.ready = "1";
        return;
      }
      const wanted = this.sceneFromUrl();
      const id = scenes.some((s) => s.scene_id === wanted) ? wanted : scenes[0].scene_id;
      picker.value = id;
      await this.load(id);
    } catch (err) {
      this.fail(err);
    }
  }

  sceneFromUrl() {
    const hash = new URLSearchParams(location.hash.slice(1));
    return hash.get("scene") || new URLSearchParams(location.search).get("scene");
  }

  maxQuery() {
    const max = new URLSearchParams(location.hash.slice(1)).get("max");
    return max ? `?max=${encodeURIComponent(max)}` : "";
  }

  async load(id) {
    const token = ++this.loadToken;
    body.dataset.ready = "0";
    this.status(`loading ${id}…`);
    // Without its Gaussians a scene is still drawn: boxes, labels and edges.
    const [doc, splats] = await Promise.all([
      getJSON(sceneUrl(id)),
      request(`${sceneUrl(id)}/splats${this.maxQuery()}`)
        .then(async (r) => decodePayload(await r.arrayBuffer()))
        .catch((err) => noSplats(err.message)),
    ]);
    if (token !== this.loadToken) return;
    this.scene = doc;
    this.entities = doc.entities;
    this.byId = new Map(doc.entities.map((e) => [e.id, e]));
    this.slotOf = new Map(doc.entities.map((e, i) => [e.id, i + 1]));
    this.palette = splats.header.palette;
    this.highlightColor = splats.header.highlight || this.highlightColor;
    this.renderer.highlight = hexToUnit(this.highlightColor);
    this.renderer.setSplats(splats, (eid) => this.slotOf.get(eid) || 0);
    this.highlighted = new Set();
    this.selected = null;
    this.camera = new OrbitCamera(doc.meta.up_axis || "z");
    this.resize(false);
    const [lo, hi] = this.bounds(splats);
    this.camera.fit(lo, hi);
    this.overlay.setEntities(doc.entities, (eid) => this.colorOf(eid));
    $("show-boxes").checked = splats.header.count === 0; // boxes stand in for Gaussians
    this.fillSceneInfo(doc, splats.header);
    this.fillRelationToggles();
    this.fillEntityList();
    this.clearAnswer();
    this.showCard(null);
    body.dataset.scene = id;
    body.dataset.splats = String(splats.header.count);
    const hash = new URLSearchParams(location.hash.slice(1));
    if (hash.get("scene") !== id) {
      hash.set("scene", id);
      history.replaceState(null, "", `#${hash}`);
    }
    this.status(splats.header.count ? "" : `no Gaussians: ${splats.header.reason || "none stored"}`);
    this.updateSlots();
    this.drawNow();
    requestAnimationFrame(() => {
      if (token === this.loadToken) body.dataset.ready = "1";
    });
  }

  // The box to frame: the entities' boxes (structure included), else the Gaussians'.
  bounds(splats) {
    const lo = [Infinity, Infinity, Infinity];
    const hi = [-Infinity, -Infinity, -Infinity];
    const grow = (p, q) => {
      for (let k = 0; k < 3; k++) {
        lo[k] = Math.min(lo[k], p[k]);
        hi[k] = Math.max(hi[k], q[k]);
      }
    };
    for (const e of this.entities) if (!ALWAYS_HIDDEN.has(e.category)) grow(e.bbox_min, e.bbox_max);
    const p = splats.position;
    if (!Number.isFinite(lo[0]) && p && p.length) {
      for (let i = 0; i < p.length; i += 3) grow([p[i], p[i + 1], p[i + 2]], [p[i], p[i + 1], p[i + 2]]);
    }
    if (!Number.isFinite(lo[0])) return [[-1, -1, -1], [1, 1, 1]];
    return [lo, hi];
  }

  // ---- state ----------------------------------------------------------------------------

  colorOf(id) { return this.palette[String(id)] || "#cccccc"; }

  visible(id) {
    const e = this.byId.get(id);
    if (!e) return false;
    if (ALWAYS_HIDDEN.has(e.category)) return false;
    return this.showWalls || e.category !== "wall";
  }

  labelled(id) {
    const e = this.byId.get(id);
    return $("show-labels").checked && (!STRUCTURE.has(e.category) || this.selected === id
      || this.highlighted.has(id));
  }

  updateSlots() {
    const n = this.entities.length + 1;
    const colors = new Array(n).fill("#808080");
    const hot = new Array(n).fill(false);
    const hidden = new Array(n).fill(false);
    for (const e of this.entities) {
      const s = this.slotOf.get(e.id);
      colors[s] = this.colorOf(e.id);
      hot[s] = this.highlighted.has(e.id);
      hidden[s] = !this.visible(e.id);
    }
    this.renderer.setSlots(colors, hot, hidden);
    this.renderer.dim = this.highlighted.size > 0;
    body.dataset.highlighted = [...this.highlighted].sort((a, b) => a - b).join(" ");
    body.dataset.selected = this.selected == null ? "" : String(this.selected);
  }

  select(id) {
    this.selected = id;
    this.updateSlots();
    this.showCard(id);
    this.redraw();
  }

  highlight(ids) {
    this.highlighted = new Set(ids);
    this.updateSlots();
    this.redraw();
  }

  focus(id) {
    const e = this.byId.get(id);
    if (!e) return;
    this.camera.target = [...e.centroid];
    const size = Math.hypot(...e.bbox_max.map((v, k) => v - e.bbox_min[k]));
    this.camera.distance = Math.max(size * 2.2, this.camera.near * 20);
    this.redraw();
  }

  // ---- drawing --------------------------------------------------------------------------

  resize(redraw = true) {
    const stage = $("stage");
    const dpr = window.devicePixelRatio || 1;
    const w = Math.max(1, stage.clientWidth);
    const h = Math.max(1, stage.clientHeight);
    for (const c of [this.glCanvas, this.overlayCanvas]) {
      c.width = Math.round(w * dpr);
      c.height = Math.round(h * dpr);
    }
    this.camera.width = w;
    this.camera.height = h;
    if (redraw) this.redraw();
  }

  redraw() {
    if (this.frameRequested) return;
    this.frameRequested = true;
    requestAnimationFrame(() => {
      this.frameRequested = false;
      this.drawNow();
    });
  }

  drawNow() {
    const dpr = window.devicePixelRatio || 1;
    this.renderer.draw(this.camera, dpr, BACKGROUND);
    if (!this.scene) return;
    this.overlay.draw({
      camera: this.camera,
      view: this.camera.view(),
      dpr,
      entities: this.entities,
      byId: this.byId,
      colorOf: (id) => this.colorOf(id),
      visible: (id) => this.visible(id),
      labelled: (id) => this.labelled(id),
      relations: this.scene.relations,
      relationOn: (t) => this.relationsOn.has(t),
      selected: this.selected,
      highlighted: this.highlighted,
      highlightColor: this.highlightColor,
      boxes: $("show-boxes").checked,
    });
  }

  // ---- picking --------------------------------------------------------------------------

  // The visible entity whose box the ray through (x, y) enters, the smallest such box.
  pick(x, y) {
    const { origin, dir } = this.camera.ray(x, y);
    let best = null;
    let bestVolume = Infinity;
    for (const e of this.entities) {
      if (!this.visible(e.id) || STRUCTURE.has(e.category)) continue;
      let t0 = 0;
      let t1 = Infinity;
      for (let k = 0; k < 3; k++) {
        const inv = 1 / dir[k];
        let a = (e.bbox_min[k] - origin[k]) * inv;
        let b = (e.bbox_max[k] - origin[k]) * inv;
        if (a > b) [a, b] = [b, a];
        t0 = Math.max(t0, a);
        t1 = Math.min(t1, b);
      }
      if (t0 > t1) continue;
      const vol = e.bbox_max.reduce((acc, v, k) => acc * Math.max(v - e.bbox_min[k], 1e-3), 1);
      if (vol < bestVolume) {
        best = e.id;
        bestVolume = vol;
      }
    }
    return best;
  }

  // ---- panels ---------------------------------------------------------------------------

  fillSceneInfo(doc, header) {
    const shown = header.count === header.total ? `${header.count}`
      : `${header.count} of ${header.total} (the largest)`;
    $("scene-info").textContent = `${doc.entities.length} entities, ${doc.relations.length} relations, `
      + `${shown} Gaussians; units ${doc.meta.units}, up ${doc.meta.up_axis}`;
  }

  fillRelationToggles() {
    const counts = new Map();
    for (const r of this.scene.relations) counts.set(r.predicate, (counts.get(r.predicate) || 0) + 1);
    const box = $("relation-toggles");
    box.replaceChildren();
    if (counts.size === 0) box.append(el("p", { className: "muted", textContent: "none stored" }));
    for (const [type, n] of [...counts].sort()) {
      const input = el("input", { type: "checkbox", checked: this.relationsOn.has(type) });
      input.dataset.relation = type;
      input.addEventListener("change", () => {
        if (input.checked) this.relationsOn.add(type);
        else this.relationsOn.delete(type);
        this.redraw();
      });
      const swatch = el("span", { className: "swatch" });
      swatch.style.background = RELATION_COLORS[type] || "#dddddd";
      box.append(el("label", {}, input, swatch, `${type.replaceAll("_", " ")} (${n})`));
    }
  }

  fillEntityList() {
    const list = $("entity-list");
    list.replaceChildren(...this.entities.map((e) => {
      const dot = el("span", { className: "dot" });
      dot.style.background = this.colorOf(e.id);
      const li = el("li", {}, dot, `${e.id} ${e.category}`);
      li.addEventListener("click", () => this.select(e.id));
      li.addEventListener("dblclick", () => this.focus(e.id));
      return li;
    }));
    $("entity-list-box").querySelector("summary").textContent = `Entities (${this.entities.length})`;
  }

  entityLink(id) {
    const e = this.byId.get(id);
    const a = el("a", { className: "entity-link", textContent: e ? `${e.category} ${id}` : `${id}` });
    a.addEventListener("click", () => this.select(id));
    return a;
  }

  showCard(id) {
    const card = $("entity-card");
    const e = id == null ? null : this.byId.get(id);
    if (!e) {
      card.hidden = true;
      return;
    }
    card.hidden = false;
    const dot = el("span", { className: "dot" });
    dot.style.background = this.colorOf(e.id);
    dot.style.display = "inline-block";
    dot.style.marginRight = "6px";
    $("card-title").replaceChildren(dot, `${e.category} ${e.id}`);
    const facts = [["id", e.id], ["external id", e.external_id], ["caption", e.caption],
      ["centroid", e.centroid], ["box min", e.bbox_min], ["box max", e.bbox_max],
      ["Gaussians", e.point_count], ["confidence", e.confidence]];
    $("card-facts").replaceChildren(...facts.filter(([, v]) => v != null && v !== "")
      .flatMap(([k, v]) => [el("dt", { textContent: k }), el("dd", { textContent: fmt(v) })]));
    const attrs = e.attributes || [];
    $("card-attributes").replaceChildren(...(attrs.length ? attrs.map((a) =>
      el("li", { textContent: `${a.key}: ${a.value} (${a.source})` }))
      : [el("li", { className: "muted", textContent: "none" })]));
    const rels = this.scene.relations.filter((r) => r.subject === id || r.object === id);
    $("card-relations").replaceChildren(...(rels.length ? rels.map((r) => {
      const li = el("li");
      li.append(this.entityLink(r.subject), ` ${r.predicate.replaceAll("_", " ")} `,
        this.entityLink(r.object));
      return li;
    }) : [el("li", { className: "muted", textContent: "none" })]));
  }

  // ---- ask ------------------------------------------------------------------------------

  async ask(question) {
    if (!this.scene || !question.trim()) return;
    body.dataset.ask = "pending";
    $("ask-button").disabled = true;
    this.status("asking…");
    try {
      const res = await request(`${sceneUrl(this.scene.scene_id)}/ask`, {
        method: "POST",
        headers: { "Content-Type": "application/json" },
        body: JSON.stringify({ question, reasoner: "offline" }),
      });
      const doc = await res.json();
      this.showAnswer(doc);
      this.highlight(doc.answer || []);
      body.dataset.ask = "done";
      this.status("");
    } catch (err) {
      body.dataset.ask = "error";
      this.status(err.message, true);
    } finally {
      $("ask-button").disabled = false;
    }
  }

  showAnswer(doc) {
    $("answer").hidden = false;
    const summary = $("answer-summary");
    summary.replaceChildren();
    const ids = doc.answer || [];
    if (doc.value != null) summary.append(`${doc.query_type}: ${doc.value} `);
    if (ids.length === 0) summary.append("no entity answers this");
    ids.forEach((id, i) => {
      if (i) summary.append(", ");
      const link = this.entityLink(id);
      link.classList.add("hit");
      summary.append(link);
    });
    $("answer-explanation").textContent = doc.explanation || "";
    $("answer-program").textContent = doc.program_text || "";
    const cands = doc.candidates || [];
    $("answer-candidates").replaceChildren(...cands.slice(0, 8).map((c) => el("li", {
      className: c.chosen ? "chosen" : "",
      textContent: `${c.category} ${Number(c.score).toFixed(2)}${c.evidence && c.evidence.length
        ? ` (${c.evidence.slice(0, 2).join("; ")})` : ""}`,
    })));
    $("answer-candidates-box").hidden = cands.length === 0;
  }

  clearAnswer() {
    $("answer").hidden = true;
    body.dataset.ask = "idle";
    if (this.highlighted.size) this.highlight([]);
  }

  // ---- ui -------------------------------------------------------------------------------

  status(text, error = false) {
    const s = $("status");
    s.textContent = text;
    s.classList.toggle("error", error);
  }

  fail(err) {
    this.status(err.message || String(err), true);
    if (!(err instanceof ApiError)) console.error(err);
  }

  bindUi() {
    $("scene-picker").addEventListener("change", (ev) => this.load(ev.target.value).catch((e) => this.fail(e)));
    $("ask-form").addEventListener("submit", (ev) => {
      ev.preventDefault();
      this.ask($("ask-input").value);
    });
    $("clear-answer").addEventListener("click", () => this.clearAnswer());
    $("close-card").addEventListener("click", () => this.select(null));
    for (const input of document.querySelectorAll('input[name="color-mode"]')) {
      input.addEventListener("change", () => {
        this.renderer.mode = input.value === "appearance" ? 1 : 0;
        this.redraw();
      });
    }
    $("show-labels").addEventListener("change", () => this.redraw());
    $("show-boxes").addEventListener("change", () => this.redraw());
    $("show-walls").addEventListener("change", (ev) => {
      this.showWalls = ev.target.checked;
      this.updateSlots();
      this.redraw();
    });
    window.addEventListener("hashchange", () => {
      const id = this.sceneFromUrl();
      if (id && this.scene && id !== this.scene.scene_id) {
        $("scene-picker").value = id;
        this.load(id).catch((e) => this.fail(e));
      }
    });
    this.bindMouse();
  }

  bindMouse() {
    const canvas = this.glCanvas;
    let drag = null;
    canvas.addEventListener("contextmenu", (ev) => ev.preventDefault());
    canvas.addEventListener("pointerdown", (ev) => {
      canvas.setPointerCapture(ev.pointerId);
      drag = { x: ev.clientX, y: ev.clientY, moved: 0, pan: ev.button === 2 || ev.shiftKey };
    });
    canvas.addEventListener("pointermove", (ev) => {
      if (!drag) return;
      const dx = ev.clientX - drag.x;
      const dy = ev.clientY - drag.y;
      drag.x = ev.clientX;
      drag.y = ev.clientY;
      drag.moved += Math.abs(dx) + Math.abs(dy);
      if (drag.pan) this.camera.pan(dx, dy);
      else this.camera.orbit(dx, dy);
      this.redraw();
    });
    canvas.addEventListener("pointerup", (ev) => {
      if (drag && drag.moved < 4 && ev.button === 0) {
        const rect = canvas.getBoundingClientRect();
        this.select(this.pick(ev.clientX - rect.left, ev.clientY - rect.top));
      }
      drag = null;
    });
    canvas.addEventListener("dblclick", (ev) => {
      const rect = canvas.getBoundingClientRect();
      const id = this.pick(ev.clientX - rect.left, ev.clientY - rect.top);
      if (id != null) this.focus(id);
    });
    canvas.addEventListener("wheel", (ev) => {
      ev.preventDefault();
      this.camera.zoom(Math.exp(ev.deltaY * 0.001));
      this.redraw();
    }, { passive: false });
  }
}

// What the page draws when the Gaussians could not be fetched (the reason is shown).
function noSplats(reason) {
  const header = { count: 0, total: 0, reason, palette: {}, highlight: "#ff00ff", arrays: [] };
  return { header, position: new Float32Array(0), scale: new Float32Array(0),
    rotation: new Int8Array(0), color: new Uint8Array(0), entity: new Int32Array(0) };
}

function hexToUnit(hex) {
  const v = parseInt(hex.slice(1), 16);
  return [((v >> 16) & 255) / 255, ((v >> 8) & 255) / 255, (v & 255) / 255];
}

let viewer;
try {
  viewer = new Viewer();
  window.causalsplatViewer = viewer;
  viewer.start();
} catch (err) {
  $("status").textContent = err.message || String(err);
  $("status").classList.add("error");
  console.error(err);
}
