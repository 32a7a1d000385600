// A WebGL2 renderer of 3D Gaussians: each Gaussian is drawn as the screen-space ellipse of
// its projected 3D covariance (the local affine approximation of the perspective
// projection), its opacity falling off as exp(-r^2/2), blended back to front after a
// depth sort on the CPU. The payload format is described in causalsplat/serve/splats.py.

const TEX_WIDTH = 2048;
const SIGMAS = "3.0"; // the quad reaches 3 standard deviations (a GLSL float)

const VERTEX = `#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
uniform sampler2D u_pos;     // xyz, entity slot
uniform sampler2D u_covA;    // c00 c01 c02 c11
uniform sampler2D u_covB;    // c12 c22 - -
uniform sampler2D u_color;   // appearance rgb, opacity
uniform sampler2D u_slots;   // row 0: entity colour; row 1: highlighted, hidden
uniform mat4 u_view;
uniform mat4 u_proj;
uniform vec2 u_viewport;     // device pixels
uniform vec2 u_focal;        // device pixels
uniform int u_mode;          // 0: entity colours, 1: appearance
uniform int u_dim;           // 1 while an answer is highlighted
uniform vec3 u_highlight;
in uint a_index;
in vec2 a_corner;
out vec4 v_color;
out vec2 v_uv;

const int W = ${TEX_WIDTH};

void main() {
  ivec2 at = ivec2(int(a_index) % W, int(a_index) / W);
  vec4 p = texelFetch(u_pos, at, 0);
  int slot = int(p.w + 0.5);
  vec4 state = texelFetch(u_slots, ivec2(slot, 1), 0);
  gl_Position = vec4(0.0, 0.0, 2.0, 1.0);
  if (state.g > 0.5) return;
  vec4 cam = u_view * vec4(p.xyz, 1.0);
  if (cam.z > -1e-3) return;
  vec4 clip = u_proj * cam;
  vec2 ndc = clip.xy / clip.w;
  if (abs(ndc.x) > 1.3 || abs(ndc.y) > 1.3) return;

  vec4 ca = texelFetch(u_covA, at, 0);
  vec4 cb = texelFetch(u_covB, at, 0);
  mat3 sigma = mat3(ca.x, ca.y, ca.z, ca.y, ca.w, cb.x, ca.z, cb.x, cb.y);
  float z = cam.z;
  mat3 jac = mat3(
    u_focal.x / -z, 0.0, 0.0,
    0.0, u_focal.y / -z, 0.0,
    u_focal.x * cam.x / (z * z), u_focal.y * cam.y / (z * z), 0.0);
  mat3 t = jac * mat3(u_view);
  mat3 cov = t * sigma * transpose(t);
  float a = cov[0][0] + 0.3;
  float b = cov[0][1];
  float d = cov[1][1] + 0.3;
  float mid = 0.5 * (a + d);
  float rad = length(vec2(0.5 * (a - d), b));
  float l1 = mid + rad;
  float l2 = max(mid - rad, 0.1);
  vec2 v1 = abs(b) > 1e-9 ? normalize(vec2(b, l1 - a)) : (a >= d ? vec2(1.0, 0.0) : vec2(0.0, 1.0));
  vec2 v2 = vec2(-v1.y, v1.x);
  vec2 axis1 = v1 * min(${SIGMAS} * sqrt(l1), 2048.0);
  vec2 axis2 = v2 * min(${SIGMAS} * sqrt(l2), 2048.0);
  vec2 offset = a_corner.x * axis1 + a_corner.y * axis2;
  gl_Position = vec4(ndc + 2.0 * offset / u_viewport, 0.0, 1.0);

  vec4 col = texelFetch(u_color, at, 0);
  vec4 ent = texelFetch(u_slots, ivec2(slot, 0), 0);
  vec3 rgb = col.rgb;
  float alpha = col.a;
  if (u_mode == 0) {
    rgb = slot == 0 ? mix(vec3(dot(col.rgb, vec3(0.3, 0.59, 0.11))), vec3(0.45), 0.5) : ent.rgb;
  }
  if (u_dim == 1) {
    if (state.r > 0.5) {
      rgb = u_highlight;
    } else {
      rgb = mix(rgb, vec3(0.32), 0.7);
      alpha *= 0.3;
    }
  }
  v_color = vec4(rgb, alpha);
  v_uv = a_corner * ${SIGMAS};
}
`;

const FRAGMENT = `#version 300 es
precision highp float;
in vec4 v_color;
in vec2 v_uv;
out vec4 outColor;
void main() {
  float r2 = dot(v_uv, v_uv);
  float alpha = v_color.a * exp(-0.5 * r2);
  if (alpha < 1.0 / 255.0) discard;
  outColor = vec4(v_color.rgb * alpha, alpha);
}
`;

function compile(gl, type, source) {
  const shader = gl.createShader(type);
  gl.shaderSource(shader, source);
  gl.compileShader(shader);
  if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) {
    throw new Error(`shader: ${gl.getShaderInfoLog(shader)}`);
  }
  return shader;
}

function program(gl, vs, fs) {
  const prog = gl.createProgram();
  gl.attachShader(prog, compile(gl, gl.VERTEX_SHADER, vs));
  gl.attachShader(prog, compile(gl, gl.FRAGMENT_SHADER, fs));
  gl.linkProgram(prog);
  if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) {
    throw new Error(`program: ${gl.getProgramInfoLog(prog)}`);
  }
  return prog;
}

// Decode a payload (ArrayBuffer) into { header, position, scale, rotation, color, entity }.
export function decodePayload(buffer) {
  const bytes = new Uint8Array(buffer);
  const magic = String.fromCharCode(bytes[0], bytes[1], bytes[2], bytes[3]);
  if (magic !== "CSPL") throw new Error("not a splat payload");
  const dv = new DataView(buffer);
  const version = dv.getUint32(4, true);
  if (version !== 1) throw new Error(`splat payload version ${version} is not supported`);
  const size = dv.getUint32(8, true);
  const header = JSON.parse(new TextDecoder().decode(bytes.subarray(12, 12 + size)));
  const base = 12 + size;
  const kinds = { "<f4": Float32Array, i1: Int8Array, u1: Uint8Array, "<i4": Int32Array };
  const out = { header };
  for (const spec of header.arrays) {
    const Kind = kinds[spec.dtype];
    out[spec.name] = new Kind(buffer, base + spec.offset, header.count * spec.components);
  }
  return out;
}

function texture(gl, unit, internal, format, type, width, height, data) {
  const tex = gl.createTexture();
  gl.activeTexture(gl.TEXTURE0 + unit);
  gl.bindTexture(gl.TEXTURE_2D, tex);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
  gl.texImage2D(gl.TEXTURE_2D, 0, internal, width, height, 0, format, type, data);
  return tex;
}

function hexToRgb(hex) {
  const v = parseInt(hex.slice(1), 16);
  return [(v >> 16) & 255, (v >> 8) & 255, v & 255];
}

export class SplatRenderer {
  constructor(canvas) {
    const gl = canvas.getContext("webgl2", {
      alpha: false, antialias: false, depth: false, preserveDrawingBuffer: true,
    });
    if (!gl) throw new Error("this browser has no WebGL2");
    this.gl = gl;
    this.canvas = canvas;
    this.prog = program(gl, VERTEX, FRAGMENT);
    this.loc = {};
    for (const name of ["u_pos", "u_covA", "u_covB", "u_color", "u_slots", "u_view", "u_proj",
      "u_viewport", "u_focal", "u_mode", "u_dim", "u_highlight"]) {
      this.loc[name] = gl.getUniformLocation(this.prog, name);
    }
    this.vao = gl.createVertexArray();
    gl.bindVertexArray(this.vao);
    const corners = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, corners);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 1, -1, -1, 1, 1, 1]), gl.STATIC_DRAW);
    const aCorner = gl.getAttribLocation(this.prog, "a_corner");
    gl.enableVertexAttribArray(aCorner);
    gl.vertexAttribPointer(aCorner, 2, gl.FLOAT, false, 0, 0);
    this.indexBuffer = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, this.indexBuffer);
    const aIndex = gl.getAttribLocation(this.prog, "a_index");
    gl.enableVertexAttribArray(aIndex);
    gl.vertexAttribIPointer(aIndex, 1, gl.UNSIGNED_INT, 0, 0);
    gl.vertexAttribDivisor(aIndex, 1);
    gl.bindVertexArray(null);
    this.count = 0;
    this.textures = [];
    this.slotTex = null;
    this.mode = 0;
    this.dim = false;
    this.highlight = [1, 0, 1];
    this.lastSortKey = null;
  }

  // Upload decoded Gaussians; slotOf maps an entity id to its slot (0: no entity).
  setSplats(data, slotOf) {
    const gl = this.gl;
    for (const t of this.textures) gl.deleteTexture(t);
    const n = data.header.count;
    this.count = n;
    this.positions = data.position;
    const height = Math.max(1, Math.ceil(n / TEX_WIDTH));
    const cells = TEX_WIDTH * height * 4;
    const pos = new Float32Array(cells);
    const covA = new Float32Array(cells);
    const covB = new Float32Array(cells);
    const col = new Uint8Array(cells);
    const { position: p, scale: s, rotation: r, color: c, entity: e } = data;
    for (let i = 0; i < n; i++) {
      pos[4 * i] = p[3 * i];
      pos[4 * i + 1] = p[3 * i + 1];
      pos[4 * i + 2] = p[3 * i + 2];
      pos[4 * i + 3] = slotOf(e[i]);
      // Sigma = R S S^T R^T from the unit quaternion (w, x, y, z) and the std-devs.
      let w = r[4 * i], x = r[4 * i + 1], y = r[4 * i + 2], z = r[4 * i + 3];
      const norm = Math.hypot(w, x, y, z) || 1;
      w /= norm; x /= norm; y /= norm; z /= norm;
      const m = [
        1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
        2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
        2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y),
      ];
      const sx = s[3 * i], sy = s[3 * i + 1], sz = s[3 * i + 2];
      const a = [m[0] * sx, m[1] * sy, m[2] * sz, m[3] * sx, m[4] * sy, m[5] * sz,
        m[6] * sx, m[7] * sy, m[8] * sz];
      covA[4 * i] = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
      covA[4 * i + 1] = a[0] * a[3] + a[1] * a[4] + a[2] * a[5];
      covA[4 * i + 2] = a[0] * a[6] + a[1] * a[7] + a[2] * a[8];
      covA[4 * i + 3] = a[3] * a[3] + a[4] * a[4] + a[5] * a[5];
      covB[4 * i] = a[3] * a[6] + a[4] * a[7] + a[5] * a[8];
      covB[4 * i + 1] = a[6] * a[6] + a[7] * a[7] + a[8] * a[8];
      col[4 * i] = c[4 * i];
      col[4 * i + 1] = c[4 * i + 1];
      col[4 * i + 2] = c[4 * i + 2];
      col[4 * i + 3] = c[4 * i + 3];
    }
    this.textures = [
      texture(gl, 0, gl.RGBA32F, gl.RGBA, gl.FLOAT, TEX_WIDTH, height, pos),
      texture(gl, 1, gl.RGBA32F, gl.RGBA, gl.FLOAT, TEX_WIDTH, height, covA),
      texture(gl, 2, gl.RGBA32F, gl.RGBA, gl.FLOAT, TEX_WIDTH, height, covB),
      texture(gl, 3, gl.RGBA8, gl.RGBA, gl.UNSIGNED_BYTE, TEX_WIDTH, height, col),
    ];
    this.depth = new Float32Array(n);
    this.keys = new Uint16Array(n);
    this.order = new Uint32Array(n);
    this.lastSortKey = null;
  }

  // Per-slot colours ("#rrggbb"), and which slots are highlighted or hidden (booleans).
  setSlots(colors, highlighted, hidden) {
    const gl = this.gl;
    const n = colors.length;
    const data = new Uint8Array(n * 2 * 4);
    for (let i = 0; i < n; i++) {
      const [r, g, b] = hexToRgb(colors[i]);
      data.set([r, g, b, 255], 4 * i);
      data.set([highlighted[i] ? 255 : 0, hidden[i] ? 255 : 0, 0, 255], 4 * (n + i));
    }
    if (this.slotTex) gl.deleteTexture(this.slotTex);
    this.slotTex = texture(gl, 4, gl.RGBA8, gl.RGBA, gl.UNSIGNED_BYTE, n, 2, data);
  }

  // Order the Gaussians far to near along the view direction (a 16-bit counting sort).
  sort(view) {
    const n = this.count;
    const key = Array.from(view).map((v) => v.toFixed(4)).join(",");
    if (n === 0 || key === this.lastSortKey) return;
    this.lastSortKey = key;
    const p = this.positions;
    const depth = this.depth;
    let lo = Infinity, hi = -Infinity;
    const m2 = view[2], m6 = view[6], m10 = view[10];
    for (let i = 0; i < n; i++) {
      const d = m2 * p[3 * i] + m6 * p[3 * i + 1] + m10 * p[3 * i + 2];
      depth[i] = d;
      if (d < lo) lo = d;
      if (d > hi) hi = d;
    }
    const scaleK = hi > lo ? 65535 / (hi - lo) : 0;
    const counts = new Uint32Array(65536);
    const keys = this.keys;
    for (let i = 0; i < n; i++) {
      const k = ((depth[i] - lo) * scaleK) | 0;
      keys[i] = k;
      counts[k]++;
    }
    let total = 0;
    for (let k = 0; k < 65536; k++) {
      const c = counts[k];
      counts[k] = total;
      total += c;
    }
    const order = this.order;
    for (let i = 0; i < n; i++) order[counts[keys[i]]++] = i;
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.indexBuffer);
    gl.bufferData(gl.ARRAY_BUFFER, order, gl.DYNAMIC_DRAW);
  }

  // Draw with the camera's matrices; dpr: device pixels per CSS pixel.
  draw(camera, dpr, background) {
    const gl = this.gl;
    gl.viewport(0, 0, this.canvas.width, this.canvas.height);
    gl.clearColor(background[0], background[1], background[2], 1);
    gl.clear(gl.COLOR_BUFFER_BIT);
    if (this.count === 0 || !this.slotTex) return;
    const view = camera.view();
    this.sort(view);
    gl.useProgram(this.prog);
    gl.bindVertexArray(this.vao);
    this.textures.forEach((t, i) => {
      gl.activeTexture(gl.TEXTURE0 + i);
      gl.bindTexture(gl.TEXTURE_2D, t);
    });
    gl.activeTexture(gl.TEXTURE4);
    gl.bindTexture(gl.TEXTURE_2D, this.slotTex);
    const L = this.loc;
    gl.uniform1i(L.u_pos, 0);
    gl.uniform1i(L.u_covA, 1);
    gl.uniform1i(L.u_covB, 2);
    gl.uniform1i(L.u_color, 3);
    gl.uniform1i(L.u_slots, 4);
    gl.uniformMatrix4fv(L.u_view, false, view);
    gl.uniformMatrix4fv(L.u_proj, false, camera.projection());
    gl.uniform2f(L.u_viewport, this.canvas.width, this.canvas.height);
    const [fx, fy] = camera.focal();
    gl.uniform2f(L.u_focal, fx * dpr, fy * dpr);
    gl.uniform1i(L.u_mode, this.mode);
    gl.uniform1i(L.u_dim, this.dim ? 1 : 0);
    gl.uniform3f(L.u_highlight, this.highlight[0], this.highlight[1], this.highlight[2]);
    gl.enable(gl.BLEND);
    gl.blendFunc(gl.ONE, gl.ONE_MINUS_SRC_ALPHA);
    gl.drawArraysInstanced(gl.TRIANGLE_STRIP, 0, 4, this.count);
    gl.bindVertexArray(null);
  }
}
