// What is drawn over the Gaussians: entity boxes and graph edges on a 2D canvas, and the
// entity labels as HTML elements (so that they can be clicked).

// One colour per relation type (none near the magenta of a highlighted answer).
export const RELATION_COLORS = {
  supported_by: "#ffd166",
  supports: "#ffd166",
  above: "#8ecae6",
  below: "#8ecae6",
  inside: "#95d5b2",
  contains: "#95d5b2",
  near: "#e9edc9",
  next_to: "#f4a261",
  left_of: "#bde0fe",
  right_of: "#bde0fe",
  in_front_of: "#ffafcc",
  behind: "#ffafcc",
};
const SYMMETRIC = new Set(["near", "next_to"]);

// The segment a-b (view space) clipped to z <= -near, or null when behind the camera.
function clipSegment(a, b, near) {
  const za = a[2] + near;
  const zb = b[2] + near;
  if (za > 0 && zb > 0) return null;
  if (za <= 0 && zb <= 0) return [a, b];
  const t = za / (za - zb);
  const m = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), -near];
  return za > 0 ? [m, b] : [a, m];
}

function boxCorners(lo, hi) {
  const out = [];
  for (let i = 0; i < 8; i++) {
    out.push([i & 1 ? hi[0] : lo[0], i & 2 ? hi[1] : lo[1], i & 4 ? hi[2] : lo[2]]);
  }
  return out;
}
const BOX_EDGES = [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7],
  [0, 4], [1, 5], [2, 6], [3, 7]];

export class Overlay {
  // onPick(id) on a click on a label, onFocus(id) on a double-click.
  constructor(canvas, labelLayer, onPick, onFocus) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.labelLayer = labelLayer;
    this.onPick = onPick;
    this.onFocus = onFocus;
    this.labels = new Map();
  }

  // Rebuild the label elements for a scene's entities.
  setEntities(entities, colorOf) {
    this.labelLayer.replaceChildren();
    this.labels.clear();
    for (const e of entities) {
      const el = document.createElement("button");
      el.type = "button";
      el.className = "label";
      el.dataset.entity = String(e.id);
      el.style.setProperty("--entity-color", colorOf(e.id));
      el.textContent = `${e.category} ${e.id}`;
      el.title = `${e.category} (entity ${e.id})`;
      el.addEventListener("click", (ev) => {
        ev.stopPropagation();
        this.onPick(e.id);
      });
      el.addEventListener("dblclick", (ev) => {
        ev.stopPropagation();
        this.onFocus(e.id);
      });
      this.labelLayer.appendChild(el);
      this.labels.set(e.id, el);
    }
  }

  // state: { camera, view, dpr, entities, byId, colorOf, visible(id), labelled(id),
  //          relations, relationOn(type), selected, highlighted (Set), highlightColor,
  //          boxes (bool) }
  draw(state) {
    const { camera, view, dpr } = state;
    const ctx = this.ctx;
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.clearRect(0, 0, camera.width, camera.height);
    const toScreen = (v) => camera.viewToScreen(v);
    const line = (a, b) => {
      const seg = clipSegment(camera.toView(view, a), camera.toView(view, b), camera.near);
      if (!seg) return null;
      const p = toScreen(seg[0]);
      const q = toScreen(seg[1]);
      ctx.moveTo(p[0], p[1]);
      ctx.lineTo(q[0], q[1]);
      return [p, q];
    };

    // Boxes: every visible entity's when asked for, and always the selected and answer ones.
    for (const e of state.entities) {
      if (!state.visible(e.id)) continue;
      const hot = state.highlighted.has(e.id);
      const sel = state.selected === e.id;
      if (!(state.boxes || hot || sel)) continue;
      const c = boxCorners(e.bbox_min, e.bbox_max);
      ctx.beginPath();
      for (const [i, j] of BOX_EDGES) line(c[i], c[j]);
      ctx.strokeStyle = hot ? state.highlightColor : sel ? "#ffffff" : state.colorOf(e.id);
      ctx.globalAlpha = hot || sel ? 1 : 0.55;
      ctx.lineWidth = hot ? 3 : sel ? 2 : 1;
      ctx.stroke();
    }
    ctx.globalAlpha = 1;

    // Edges of the graph, centroid to centroid, an arrow head towards the object.
    const seen = new Set();
    for (const r of state.relations) {
      if (!state.relationOn(r.predicate)) continue;
      if (!state.visible(r.subject) || !state.visible(r.object)) continue;
      const a = state.byId.get(r.subject);
      const b = state.byId.get(r.object);
      if (!a || !b) continue;
      const symmetric = SYMMETRIC.has(r.predicate);
      if (symmetric) {
        const key = `${r.predicate}:${Math.min(r.subject, r.object)}:${Math.max(r.subject, r.object)}`;
        if (seen.has(key)) continue;
        seen.add(key);
      }
      const touches = state.selected === r.subject || state.selected === r.object;
      ctx.beginPath();
      const seg = line(a.centroid, b.centroid);
      if (!seg) continue;
      ctx.strokeStyle = RELATION_COLORS[r.predicate] || "#dddddd";
      ctx.lineWidth = touches ? 3 : 2;
      ctx.globalAlpha = state.selected == null || touches ? 0.95 : 0.45;
      ctx.stroke();
      if (!symmetric) {
        const [p, q] = seg;
        const dx = q[0] - p[0], dy = q[1] - p[1];
        const len = Math.hypot(dx, dy);
        if (len > 24) {
          const ux = dx / len, uy = dy / len;
          const tip = [p[0] + dx * 0.6, p[1] + dy * 0.6];
          ctx.beginPath();
          ctx.moveTo(tip[0] + ux * 5, tip[1] + uy * 5);
          ctx.lineTo(tip[0] - ux * 6 - uy * 5, tip[1] - uy * 6 + ux * 5);
          ctx.lineTo(tip[0] - ux * 6 + uy * 5, tip[1] - uy * 6 - ux * 5);
          ctx.closePath();
          ctx.fillStyle = ctx.strokeStyle;
          ctx.fill();
        }
      }
    }
    ctx.globalAlpha = 1;

    // Centroid dots.
    for (const e of state.entities) {
      if (!state.visible(e.id)) continue;
      const v = camera.toView(view, e.centroid);
      if (v[2] > -camera.near) continue;
      const [x, y] = toScreen(v);
      ctx.beginPath();
      ctx.arc(x, y, state.highlighted.has(e.id) ? 5 : 3, 0, 2 * Math.PI);
      ctx.fillStyle = state.highlighted.has(e.id) ? state.highlightColor : state.colorOf(e.id);
      ctx.strokeStyle = "#111111";
      ctx.lineWidth = 1;
      ctx.fill();
      ctx.stroke();
    }

    // Labels, above the top of each box.
    for (const e of state.entities) {
      const el = this.labels.get(e.id);
      if (!el) continue;
      const show = state.visible(e.id) && state.labelled(e.id);
      const top = [...e.centroid];
      const up = camera.up.indexOf(1);
      top[up] = e.bbox_max[up];
      const v = camera.toView(view, top);
      if (!show || v[2] > -camera.near) {
        el.hidden = true;
        continue;
      }
      const [x, y] = toScreen(v);
      if (x < -50 || y < -20 || x > camera.width + 50 || y > camera.height + 20) {
        el.hidden = true;
        continue;
      }
      el.hidden = false;
      el.style.transform = `translate(${x.toFixed(1)}px, ${y.toFixed(1)}px) translate(-50%, -120%)`;
      el.classList.toggle("hot", state.highlighted.has(e.id));
      el.classList.toggle("selected", state.selected === e.id);
    }
  }
}
