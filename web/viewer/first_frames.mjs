// SPDX-License-Identifier: Apache-2.0
// The first frames, drawn before three.js is ready: a small hand-written WebGL 2 program that
// draws the components that have arrived under their instances' matrices, with the page's camera,
// hidden parts, highlight and clipping plane, lit as the bone material lights them
// (render_three.mjs, scene.mjs): a hemisphere light and a head light on a MeshStandardMaterial
// (roughness 0.6, no metal, both sides), sRGB output. Each component is drawn at its first,
// coarsest level until the page's levels of detail (levels.mjs) swap a finer one in, as they do
// with three.js's scene: finer levels are held as they arrive and drawn when the page says so. The
// render worker (render_worker.mjs) draws with it once its WebGL context exists and until
// three.js's import begins, and disposes of it when three.js's view is made; three.js then draws
// the same meshes, from the same arrays, and its frame matches these to a few pixels (a browser
// test compares them).
//
// Why: three.js is most of the viewer's code. Parsing it, making its renderer and compiling the
// bone material's programs take longer than the first chunks take to arrive and decode; this
// program is a few dozen lines of GLSL and links in tens of milliseconds with a software GPU.
// Drawing is one call per instance (no instancing: a skeleton has a few hundred).
//
// The colours and lights are copies of scene.mjs's, render_three.mjs's and camera.mjs's (those
// modules import three.js, which this one must not). It leaves the context as three.js expects
// to find it (no program, vertex array or buffer bound, the default state).
//
// Based on: three.js's physically based shading (meshphysical.glsl: BRDF_Lambert, BRDF_GGX,
// the hemisphere light's irradiance) reduced to the two lights and the one material the viewer uses.

const kVertex = `#version 300 es
in vec3 position;
in vec3 normal;
uniform mat4 model;
uniform mat4 view;
uniform mat4 projection;
out vec3 vNormal;     // in view space
out vec3 vPosition;   // in view space
out vec3 vWorld;
void main() {
  vec4 world = model * vec4(position, 1.0);
  vec4 eye = view * world;
  vWorld = world.xyz;
  vPosition = eye.xyz;
  vNormal = mat3(view) * (transpose(inverse(mat3(model))) * normal);
  gl_Position = projection * eye;
}`;

const kFragment = `#version 300 es
precision highp float;
in vec3 vNormal;
in vec3 vPosition;
in vec3 vWorld;
uniform vec3 diffuse;        // linear
uniform vec3 hemiUp;         // the hemisphere light's up, in view space
uniform vec3 sky;            // linear, times its intensity
uniform vec3 ground;
uniform vec3 lightDir;       // towards the head light, in view space
uniform vec3 lightColor;     // linear, times its intensity
uniform vec4 clipPlane;      // world: kept where dot(normal, p) + constant >= 0
uniform float clipOn;
uniform float flip;          // -1 for a mirrored instance (its triangles wind the other way)
out vec4 color;
const float PI = 3.141592653589793;
vec3 srgb(vec3 c) {
  return mix(pow(c, vec3(0.41666)) * 1.055 - vec3(0.055), c * 12.92, vec3(lessThanEqual(c, vec3(0.0031308))));
}
void main() {
  if (clipOn > 0.5 && dot(clipPlane.xyz, vWorld) + clipPlane.w < 0.0) discard;
  vec3 n = normalize(vNormal) * (gl_FrontFacing ? 1.0 : -1.0) * flip;
  vec3 v = normalize(-vPosition);
  // Roughness as three.js sets it: the material's, plus the geometry's own (its normals' change
  // across the pixel).
  vec3 dxy = max(abs(dFdx(normalize(vNormal))), abs(dFdy(normalize(vNormal))));
  float roughness = min(0.6 + max(max(dxy.x, dxy.y), dxy.z), 1.0);
  float alpha = roughness * roughness;
  vec3 l = normalize(lightDir);
  float nl = clamp(dot(n, l), 0.0, 1.0);
  vec3 h = normalize(l + v);
  float nv = clamp(dot(n, v), 0.0, 1.0);
  float nh = clamp(dot(n, h), 0.0, 1.0);
  float vh = clamp(dot(v, h), 0.0, 1.0);
  float fresnel = pow(1.0 - vh, 5.0);
  vec3 f = vec3(0.04) * (1.0 - fresnel) + vec3(fresnel);
  float a2 = alpha * alpha;
  float gv = nl * sqrt(a2 + (1.0 - a2) * nv * nv);
  float gl = nv * sqrt(a2 + (1.0 - a2) * nl * nl);
  float visibility = 0.5 / max(gv + gl, 1e-6);
  float denom = nh * nh * (a2 - 1.0) + 1.0;
  float d = a2 / (PI * denom * denom);
  vec3 irradiance = mix(ground, sky, 0.5 * dot(n, normalize(hemiUp)) + 0.5);
  vec3 light = (irradiance + nl * lightColor) * diffuse / PI + nl * lightColor * f * visibility * d;
  color = vec4(srgb(light), 1.0);
}`;

const kBone = 0xd9cdb5;        // scene.mjs kBoneColor
const kHighlight = 0xff7a2e;   // scene.mjs kHighlight
const kBackground = 0x1c2027;  // camera.mjs kBackground
const kSky = [0xffffff, 0.7];  // render_three.mjs: HemisphereLight(0xffffff, 0x4a4036, 0.7)
const kGround = [0x4a4036, 0.7];
const kHead = [0xffffff, 2.4]; // DirectionalLight(0xffffff, 2.4) at (0.6, 0.9, 1), looking at (0, 0, -1), in camera space
const kHeadDir = [0.6, 0.9, 2];

const toLinear = (c) => (c <= 0.04045 ? c * 0.0773993808 : ((c * 0.9478672986 + 0.0521327014) ** 2.4));
const hexRgb = (hex) => [(hex >> 16) & 255, (hex >> 8) & 255, hex & 255].map((c) => c / 255);
const linear = (rgb) => rgb.map(toLinear);

/// A column-major 4x4 matrix: the camera's world matrix inverted (position, quaternion).
function viewMatrix(p, q) {
  const [x, y, z, w] = q;
  // The rotation's columns (three.js Matrix4.compose with scale 1).
  const r = [
    1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w),
    2 * (x * y - z * w), 1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
    2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y),
  ];
  // Inverse of [R | p]: [R^T | -R^T p].
  const m = new Float32Array(16);
  for (let i = 0; i < 3; ++i) {
    for (let j = 0; j < 3; ++j) m[j * 4 + i] = r[i * 3 + j];
    m[12 + i] = -(r[i * 3] * p[0] + r[i * 3 + 1] * p[1] + r[i * 3 + 2] * p[2]);
  }
  m[15] = 1;
  return m;
}

/// three.js PerspectiveCamera's projection (zoom 1, no view offset).
function projectionMatrix({ fov, aspect, near, far }) {
  const top = near * Math.tan((Math.PI / 360) * fov);
  const right = top * aspect;
  const m = new Float32Array(16);
  m[0] = near / right;
  m[5] = near / top;
  m[10] = -(far + near) / (far - near);
  m[11] = -1;
  m[14] = (-2 * far * near) / (far - near);
  return m;
}

/// The view and projection matrices (column-major Float32Arrays, three.js's matrixWorldInverse
/// and projectionMatrix) of the page's camera message { position, quaternion, fov, aspect, near,
/// far }.
export function cameraMatrices(camera) {
  return { view: viewMatrix(camera.position, camera.quaternion), projection: projectionMatrix(camera) };
}

function compile(gl, type, source) {
  const shader = gl.createShader(type);
  gl.shaderSource(shader, source);
  gl.compileShader(shader);
  return shader;
}

/// The first frames' drawer on `gl` (a WebGL 2 context) for `manifest` (manifest.mjs), or null
/// when its program does not link (then three.js draws the first frame, as it would anyway).
/// Returns { add(id, mesh), addLevel(id, level, mesh), show(id, level), remove(id, level),
/// drawnLevel(id), draw(view), dispose() }.
export function createFirstFrames(gl, manifest) {
  const program = gl.createProgram();
  const shaders = [compile(gl, gl.VERTEX_SHADER, kVertex), compile(gl, gl.FRAGMENT_SHADER, kFragment)];
  for (const shader of shaders) gl.attachShader(program, shader);
  gl.bindAttribLocation(program, 0, 'position');
  gl.bindAttribLocation(program, 1, 'normal');
  gl.linkProgram(program);
  for (const shader of shaders) gl.deleteShader(shader);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) {
    gl.deleteProgram(program);
    return null;
  }
  const uniform = Object.fromEntries(['model', 'view', 'projection', 'diffuse', 'hemiUp', 'sky', 'ground', 'lightDir', 'lightColor', 'clipPlane', 'clipOn', 'flip']
    .map((name) => [name, gl.getUniformLocation(program, name)]));
  const bone = linear(hexRgb(kBone));
  const lit = linear(hexRgb(kHighlight));
  const partColor = manifest.parts.map((p) => (p.color ? linear(p.color) : bone));
  const meshes = new Map();  // component id -> { levels: Map(level -> { vao, buffers, count, type }), drawn }

  /// The GPU side of one level of component `component`, or null when this program cannot draw
  /// it as three.js would (counts other than the manifest's, no normals).
  function upload(component, level, { positions, normals, indices }) {
    if (!positions || !indices || !normals || normals.length !== positions.length ||
        indices.length !== component.levels[level].triangles * 3) return null;
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    const buffers = [positions, normals].map((array, location) => {
      const buffer = gl.createBuffer();
      gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
      gl.bufferData(gl.ARRAY_BUFFER, array, gl.STATIC_DRAW);
      gl.enableVertexAttribArray(location);
      gl.vertexAttribPointer(location, 3, gl.FLOAT, false, 0, 0);
      return buffer;
    });
    const index = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, index);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, indices, gl.STATIC_DRAW);
    buffers.push(index);
    gl.bindVertexArray(null);
    gl.bindBuffer(gl.ARRAY_BUFFER, null);
    const type = indices instanceof Uint16Array ? gl.UNSIGNED_SHORT : gl.UNSIGNED_INT;
    return { vao, buffers, count: indices.length, type };
  }

  function release(entry) {
    gl.deleteVertexArray(entry.vao);
    for (const buffer of entry.buffers) gl.deleteBuffer(buffer);
  }

  return {
    /// Uploads component `id`'s first level and draws it; false (nothing kept) when the mesh is
    /// not one this program can draw as three.js would (upload), which then waits for three.js.
    add(id, mesh) {
      const component = manifest.componentById.get(id);
      if (!component || meshes.has(id)) return false;
      const entry = upload(component, 0, mesh);
      if (!entry) return false;
      meshes.set(id, { levels: new Map([[0, entry]]), drawn: 0 });
      return true;
    },

    /// Holds finer level `level` of a component already added, not yet drawn (show); false when
    /// it is held already or cannot be drawn as three.js would.
    addLevel(id, level, mesh) {
      const held = meshes.get(id);
      const component = manifest.componentById.get(id);
      if (!held || held.levels.has(level) || !(level > 0 && level < component.levels.length)) return false;
      const entry = upload(component, level, mesh);
      if (entry) held.levels.set(level, entry);
      return entry !== null;
    },

    /// Draws component `id` at `level`, a level it holds; returns whether that changed anything.
    show(id, level) {
      const held = meshes.get(id);
      if (!held?.levels.has(level) || held.drawn === level) return false;
      held.drawn = level;
      return true;
    },

    /// Frees level `level` of component `id` (never its first); drawn, the next coarser level
    /// held is drawn instead, as three.js's scene does. Returns whether the level drawn changed.
    remove(id, level) {
      const held = meshes.get(id);
      const entry = held?.levels.get(level);
      if (!entry || level === 0) return false;
      held.levels.delete(level);
      release(entry);
      if (held.drawn !== level) return false;
      held.drawn = Math.max(...[...held.levels.keys()].filter((l) => l < level));
      return true;
    },

    /// The level component `id` is drawn at, or null when it is not drawn.
    drawnLevel(id) {
      return meshes.get(id)?.drawn ?? null;
    },

    /// Draws every component added, each instance of a shown part, on a cleared canvas.
    /// `view`: { camera (the page's 'camera' message), width, height (the drawing buffer's
    /// pixels), hidden (Uint8Array per part, or null), highlight (a part id or -1), clip (the
    /// page's 'clip' message, or null), background ('#rrggbb'; absent: the viewer's default) }.
    draw({ camera, width, height, hidden, highlight, clip, background }) {
      const { view: viewM, projection } = cameraMatrices(camera);
      gl.viewport(0, 0, width, height);
      const bg = hexRgb(background ? Number.parseInt(background.slice(1), 16) : kBackground);
      gl.clearColor(bg[0], bg[1], bg[2], 1);
      gl.clearDepth(1);
      gl.enable(gl.DEPTH_TEST);
      gl.depthFunc(gl.LEQUAL);
      gl.disable(gl.CULL_FACE);
      gl.disable(gl.BLEND);
      gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
      gl.useProgram(program);
      gl.uniformMatrix4fv(uniform.view, false, viewM);
      gl.uniformMatrix4fv(uniform.projection, false, projection);
      // The hemisphere light's up is the world's +Y (three.js's default light position).
      gl.uniform3f(uniform.hemiUp, viewM[4], viewM[5], viewM[6]);
      gl.uniform3fv(uniform.sky, linear(hexRgb(kSky[0])).map((c) => c * kSky[1]));
      gl.uniform3fv(uniform.ground, linear(hexRgb(kGround[0])).map((c) => c * kGround[1]));
      gl.uniform3fv(uniform.lightDir, kHeadDir);
      gl.uniform3fv(uniform.lightColor, linear(hexRgb(kHead[0])).map((c) => c * kHead[1]));
      gl.uniform1f(uniform.clipOn, clip?.on ? 1 : 0);
      if (clip?.on) gl.uniform4f(uniform.clipPlane, ...clip.normal, clip.constant);
      for (const [id, held] of meshes) {
        const mesh = held.levels.get(held.drawn);
        gl.bindVertexArray(mesh.vao);
        for (const i of manifest.instancesOf.get(id)) {
          const instance = manifest.instances[i];
          if (hidden?.[instance.part]) continue;
          const rgb = partColor[instance.part];
          gl.uniform3fv(uniform.diffuse, instance.part === highlight ? rgb.map((c, k) => c * lit[k]) : rgb);
          gl.uniformMatrix4fv(uniform.model, false, instance.matrix);
          gl.uniform1f(uniform.flip, instance.mirror ? -1 : 1);
          gl.drawElements(gl.TRIANGLES, mesh.count, mesh.type, 0);
        }
      }
      gl.bindVertexArray(null);
      gl.useProgram(null);
    },

    /// Frees the program and every buffer; the context is left in its default state.
    dispose() {
      for (const held of meshes.values()) for (const entry of held.levels.values()) release(entry);
      meshes.clear();
      gl.deleteProgram(program);
      gl.bindVertexArray(null);
      gl.useProgram(null);
      gl.bindBuffer(gl.ARRAY_BUFFER, null);
      gl.disable(gl.DEPTH_TEST);
      gl.depthFunc(gl.LESS);
      gl.clearColor(0, 0, 0, 0);
    },
  };
}
