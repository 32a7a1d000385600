// An orbit camera around a target point, with the scene's up axis pointing up.
// Matrices are column-major Float32Arrays, as WebGL takes them; the camera looks down -z
// of its own frame (the OpenGL convention), so view-space depth is -z.

const AXES = { x: 0, y: 1, z: 2 };

function unit(i) {
  const v = [0, 0, 0];
  v[i] = 1;
  return v;
}

export function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
export function add(a, b) { return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]; }
export function scale(a, s) { return [a[0] * s, a[1] * s, a[2] * s]; }
export function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
export function cross(a, b) {
  return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
}
export function normalize(a) {
  const n = Math.hypot(a[0], a[1], a[2]) || 1;
  return [a[0] / n, a[1] / n, a[2] / n];
}

export class OrbitCamera {
  // upAxis: "x", "y" or "z" (the scene meta's up_axis).
  constructor(upAxis = "z") {
    const u = AXES[upAxis] ?? 2;
    // Horizontal axes in cyclic order, so that X x Y = UP (a right-handed frame).
    this.up = unit(u);
    this.ax = unit((u + 1) % 3);
    this.ay = unit((u + 2) % 3);
    this.target = [0, 0, 0];
    this.distance = 5;
    this.yaw = -Math.PI / 3;
    this.pitch = 0.9;
    this.fovy = (50 * Math.PI) / 180;
    this.near = 0.02;
    this.far = 1000;
    this.width = 1;
    this.height = 1;
  }

  // Frame an axis-aligned box [lo, hi] from above at an angle.
  fit(lo, hi) {
    this.target = scale(add(lo, hi), 0.5);
    const radius = Math.max(0.25, 0.5 * Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]));
    const half = Math.min(this.fovy, this.fovy * this.aspect()) / 2;
    this.distance = (radius / Math.sin(half)) * 0.8;
    this.near = Math.max(1e-3, this.distance / 500);
    this.far = this.distance * 20 + radius * 4;
    this.yaw = -Math.PI / 3;
    this.pitch = 0.95;
  }

  aspect() { return this.width / Math.max(1, this.height); }

  eye() {
    const cp = Math.cos(this.pitch);
    const dir = add(add(scale(this.ax, cp * Math.cos(this.yaw)), scale(this.ay, cp * Math.sin(this.yaw))),
      scale(this.up, Math.sin(this.pitch)));
    return add(this.target, scale(dir, this.distance));
  }

  orbit(dx, dy) {
    this.yaw -= dx * 0.008;
    this.pitch = Math.min(1.55, Math.max(-1.55, this.pitch + dy * 0.008));
  }

  // Move the target in the view plane by a drag of (dx, dy) pixels.
  pan(dx, dy) {
    const { right, upv } = this.basis();
    const perPixel = (2 * this.distance * Math.tan(this.fovy / 2)) / Math.max(1, this.height);
    this.target = add(this.target, add(scale(right, -dx * perPixel), scale(upv, dy * perPixel)));
  }

  zoom(factor) {
    this.distance = Math.min(this.far / 2, Math.max(this.near * 4, this.distance * factor));
  }

  basis() {
    const eye = this.eye();
    const fwd = normalize(sub(this.target, eye));
    let right = cross(fwd, this.up);
    if (Math.hypot(...right) < 1e-6) right = this.ax;
    right = normalize(right);
    const upv = cross(right, fwd);
    return { eye, fwd, right, upv };
  }

  view() {
    const { eye, fwd, right, upv } = this.basis();
    return new Float32Array([
      right[0], upv[0], -fwd[0], 0,
      right[1], upv[1], -fwd[1], 0,
      right[2], upv[2], -fwd[2], 0,
      -dot(right, eye), -dot(upv, eye), dot(fwd, eye), 1,
    ]);
  }

  projection() {
    const f = 1 / Math.tan(this.fovy / 2);
    const { near: n, far: fa } = this;
    return new Float32Array([
      f / this.aspect(), 0, 0, 0,
      0, f, 0, 0,
      0, 0, (fa + n) / (n - fa), -1,
      0, 0, (2 * fa * n) / (n - fa), 0,
    ]);
  }

  // Focal lengths in pixels (for the splat footprints).
  focal() {
    const fy = this.height / (2 * Math.tan(this.fovy / 2));
    return [fy, fy];
  }

  // A world point in view space ([x, y, z], z < 0 in front of the camera).
  toView(view, p) {
    return [
      view[0] * p[0] + view[4] * p[1] + view[8] * p[2] + view[12],
      view[1] * p[0] + view[5] * p[1] + view[9] * p[2] + view[13],
      view[2] * p[0] + view[6] * p[1] + view[10] * p[2] + view[14],
    ];
  }

  // A view-space point (in front of the camera) in CSS pixels of the canvas.
  viewToScreen(v) {
    const [fx, fy] = this.focal();
    return [this.width / 2 + (fx * v[0]) / -v[2], this.height / 2 - (fy * v[1]) / -v[2]];
  }

  // The world-space ray through a pixel: { origin, dir }.
  ray(px, py) {
    const { eye, fwd, right, upv } = this.basis();
    const [fx, fy] = this.focal();
    const dir = normalize(add(fwd, add(scale(right, (px - this.width / 2) / fx),
      scale(upv, -(py - this.height / 2) / fy))));
    return { origin: eye, dir };
  }
}
