// Locard case viewer: a single page served by `locard view` on 127.0.0.1. Everything it loads
// comes from that server (the case's files under /case/..., the JSON API under /api/...), each
// request carrying the run's token; nothing remote is referenced, so it works offline.
//
// Frames: the scene root is the case's world frame (z up, metres). glTF files are y-up by
// specification (Locard writes (x, y, z) -> (x, z, -y)), so each loaded glTF goes into a group
// rotated +90 degrees about x, which turns it back. Every coordinate sent to or read from the
// API is therefore a world coordinate as it is.
//
// Rendering is on demand: a frame is drawn only when something changed (camera, toggles, a
// playing simulation, walking, a benchmark), with the cheapest material that keeps colour
// (MeshBasicMaterial, vertex colours, no lights, no shadows) and frustum culling.
import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';

const token = new URLSearchParams(window.location.search).get('token') || '';
const withToken = (url) => url + (url.includes('?') ? '&' : '?') + 'token=' + encodeURIComponent(token);
const $ = (id) => document.getElementById(id);

async function api(path, body) {
  const init = body === undefined ? { headers: { 'X-Locard-Token': token } } : {
    method: 'POST',
    headers: { 'X-Locard-Token': token, 'Content-Type': 'application/json' },
    body: JSON.stringify(body),
  };
  const response = await fetch(path, init);
  const type = response.headers.get('Content-Type') || '';
  const data = type.includes('json') ? await response.json() : await response.arrayBuffer();
  if (!response.ok) throw new Error((data && data.error) || `${path}: HTTP ${response.status}`);
  return data;
}

const status = (text) => { $('status').textContent = text; };
const vec = (a) => new THREE.Vector3(a[0], a[1], a[2]);
const arr = (v) => [v.x, v.y, v.z];
const fmtM = (m) => `${m.toFixed(3)} m`;

// --- renderer, scene, camera -----------------------------------------------------------------
const container = $('viewport');
const renderer = new THREE.WebGLRenderer({ antialias: false, powerPreference: 'high-performance' });
renderer.setPixelRatio(Math.min(window.devicePixelRatio, 1.5));  // see applyLod
renderer.shadowMap.enabled = false;
container.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x1d2026);
const camera = new THREE.PerspectiveCamera(60, 1, 0.02, 200);
camera.up.set(0, 0, 1);
camera.position.set(0, -6, 4);
const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;
controls.screenSpacePanning = true;

const root = new THREE.Group();  // world frame, z up
scene.add(root);
const meshGroup = new THREE.Group();
const pointsGroup = new THREE.Group();
const overlayGroup = new THREE.Group();  // measurements, trajectories
const markerGroup = new THREE.Group();
const simGroup = new THREE.Group();
const coverageGroup = new THREE.Group();  // the floor the scan did not observe
root.add(meshGroup, pointsGroup, overlayGroup, markerGroup, simGroup, coverageGroup);
coverageGroup.visible = false;
pointsGroup.visible = false;

const clipPlane = new THREE.Plane(new THREE.Vector3(0, 0, -1), 0);
let bounds = new THREE.Box3(new THREE.Vector3(-3, -3, 0), new THREE.Vector3(3, 3, 3));
let floorZ = 0;

let needsRender = true;
const requestRender = () => { needsRender = true; };
controls.addEventListener('change', () => { lastMotion = performance.now(); requestRender(); });

function resize() {
  const w = container.clientWidth || 1, h = container.clientHeight || 1;
  renderer.setSize(w, h, false);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
  requestRender();
}
window.addEventListener('resize', resize);
resize();

// --- state exposed for tests and scripting -------------------------------------------------------
const state = {
  caseInfo: null, meshTriangles: 0, inferredTriangles: 0, points: 0, markers: [],
  lastMeasurement: null, lastTrajectory: null, fps: 0, frames: 0, loaded: false, error: null,
  simulation: null, lodTriangles: 0, lodLevel: -1,
  frame: null, savedMeasurements: [], savedTrajectories: [],
};

// --- the case frame (`locard marker frame`): coordinates are shown as the CLI and report print
// them; the API speaks world coordinates, the frame turns them into the case's.
function toCaseFrame(p) {
  const f = state.frame;
  const a = Array.isArray(p) ? p : [p.x, p.y, p.z];
  if (!f) return a;
  const d = [a[0] - f.origin[0], a[1] - f.origin[1], a[2] - f.origin[2]];
  const dot = (u) => u[0] * d[0] + u[1] * d[1] + u[2] * d[2];
  return [dot(f.x_axis), dot(f.y_axis), dot(f.z_axis)];
}
const fmtPoint = (p) => `(${toCaseFrame(p).map((v) => v.toFixed(3)).join(', ')})`;

// --- mesh ------------------------------------------------------------------------------------
const gltfLoader = new GLTFLoader();
const meshMaterial = new THREE.MeshBasicMaterial({ vertexColors: true });
const inferredMaterial = new THREE.MeshBasicMaterial({ color: 0xff33cc, transparent: true, opacity: 0.75 });
const inferredMeshes = [];
const pickables = [];

function asWorldGroup(gltfScene) {
  const g = new THREE.Group();
  g.rotation.x = Math.PI / 2;  // glTF y-up -> world z-up: (x, y, z) -> (x, -z, y)
  g.add(gltfScene);
  return g;
}

// Level of detail while the camera moves. A mesh above LOD_THRESHOLD triangles gets proxies
// of about LOD_TRIANGLES[k] triangles by vertex clustering (Rossignac & Borrel 1993: the
// vertices in each cell of a uniform grid merge into their mean, triangles that collapse are
// dropped). While the view changes, the viewer draws the level of LOD_LEVELS that holds
// TARGET_FPS on this machine (measured frame by frame: a fast GPU keeps the full mesh, software
// WebGL steps down to coarser proxies and fewer pixels); as soon as the view rests
// (MOTION_REST_MS) the full mesh returns at full resolution, so every still image, screenshot
// and pick uses the full mesh.
const LOD_THRESHOLD = 400000, LOD_TRIANGLES = [120000, 30000, 8000, 2000], MOTION_REST_MS = 250;
// [proxy index (-1: the full mesh), fraction of the pixel ratio], finest first. The last level
// is for software WebGL on a small CPU, where most of a frame is fixed cost: on the 2-core CI
// machine the 8k proxy at 1/4 ran 28-38 fps from one run to another, the 2k one at 1/6 37.6.
const LOD_LEVELS = [[-1, 1], [0, 1 / 2], [1, 1 / 2], [1, 1 / 3], [2, 1 / 4], [3, 1 / 6]];
const TARGET_FPS = 30;
const lod = [];  // { full, proxies: [mesh per LOD_TRIANGLES entry] }
let lastMotion = -Infinity;
// The adaptive controller: the level used while moving, decided on the mean frame time of
// windows of LOD_WINDOW frames drawn back to back (a single slow frame, a garbage collection,
// moves nothing): coarser when a window is over the budget by 10 %, finer when it is under 40 %
// of it (the finer level costing up to twice as much still fits), never finer within 3 s of
// having had to go coarser (no oscillation).
const LOD_WINDOW = 10;
const lodControl = { level: 1, sumMs: 0, frames: 0, lastFrame: 0, holdUntil: 0, skip: 3 };
function lodFrameTime(now) {
  // The first frames at a new level upload its geometry: not counted.
  if (lodControl.skip > 0) { lodControl.skip -= 1; lodControl.lastFrame = now; return; }
  if (lodControl.lastFrame > 0) {
    lodControl.sumMs += now - lodControl.lastFrame;
    lodControl.frames += 1;
    if (lodControl.frames >= LOD_WINDOW) {
      const mean = lodControl.sumMs / lodControl.frames, budget = 1000 / TARGET_FPS;
      if (mean > 1.1 * budget && lodControl.level + 1 < LOD_LEVELS.length) {
        lodControl.level += 1;
        lodControl.holdUntil = now + 3000;
        lodControl.skip = 3;
      } else if (mean < 0.4 * budget && lodControl.level > 0 && now > lodControl.holdUntil) {
        lodControl.level -= 1;
        lodControl.skip = 3;
      }
      lodControl.sumMs = 0;
      lodControl.frames = 0;
    }
  }
  lodControl.lastFrame = now;
}

function clusterVertices(geometry, targetTriangles) {
  const pos = geometry.attributes.position.array;
  const index = geometry.index.array;
  const color = geometry.attributes.color;
  let area = 0;
  const a = new THREE.Vector3(), b = new THREE.Vector3(), c = new THREE.Vector3();
  for (let t = 0; t < index.length; t += 3) {
    a.fromArray(pos, 3 * index[t]); b.fromArray(pos, 3 * index[t + 1]); c.fromArray(pos, 3 * index[t + 2]);
    area += b.sub(a).cross(c.sub(a)).length() / 2;
  }
  // About two triangles per occupied cell face: cell^2 ~ 2 * area / target.
  const cell = Math.sqrt((2 * area) / Math.max(1, targetTriangles));
  geometry.computeBoundingBox();
  const min = geometry.boundingBox.min;
  const nx = Math.ceil((geometry.boundingBox.max.x - min.x) / cell) + 1;
  const ny = Math.ceil((geometry.boundingBox.max.y - min.y) / cell) + 1;
  const n = pos.length / 3, items = color ? color.itemSize : 0;
  const cellOf = new Map(), remap = new Uint32Array(n);
  const sums = [], colorSums = [];
  for (let v = 0; v < n; ++v) {
    const ix = Math.floor((pos[3 * v] - min.x) / cell), iy = Math.floor((pos[3 * v + 1] - min.y) / cell), iz = Math.floor((pos[3 * v + 2] - min.z) / cell);
    const key = ix + nx * (iy + ny * iz);
    let id = cellOf.get(key);
    if (id === undefined) { id = cellOf.size; cellOf.set(key, id); sums.push(0, 0, 0, 0); for (let k = 0; k < items; ++k) colorSums.push(0); }
    remap[v] = id;
    sums[4 * id] += pos[3 * v]; sums[4 * id + 1] += pos[3 * v + 1]; sums[4 * id + 2] += pos[3 * v + 2]; sums[4 * id + 3] += 1;
    for (let k = 0; k < items; ++k) colorSums[items * id + k] += color.array[items * v + k];
  }
  const m = cellOf.size;
  const outPos = new Float32Array(3 * m);
  const outColor = color ? new color.array.constructor(items * m) : null;
  for (let id = 0; id < m; ++id) {
    const w = sums[4 * id + 3];
    for (let k = 0; k < 3; ++k) outPos[3 * id + k] = sums[4 * id + k] / w;
    for (let k = 0; k < items; ++k) outColor[items * id + k] = Math.round(colorSums[items * id + k] / w);
  }
  const outIndex = [];
  for (let t = 0; t < index.length; t += 3) {
    const i = remap[index[t]], j = remap[index[t + 1]], k = remap[index[t + 2]];
    if (i !== j && j !== k && i !== k) outIndex.push(i, j, k);
  }
  const out = new THREE.BufferGeometry();
  out.setAttribute('position', new THREE.BufferAttribute(outPos, 3));
  if (color) out.setAttribute('color', new THREE.BufferAttribute(outColor, items, color.normalized));
  out.setIndex(m > 65535 ? new THREE.Uint32BufferAttribute(outIndex, 1) : new THREE.Uint16BufferAttribute(outIndex, 1));
  out.computeBoundingSphere();
  return out;
}

// Shows the controller's level while the view is changing, the full meshes at full resolution
// when it rests.
const basePixelRatio = Math.min(window.devicePixelRatio, 1.5);
function applyLod(now) {
  const moving = lod.length > 0 && now - lastMotion < MOTION_REST_MS;
  const [proxyIndex, fraction] = moving ? LOD_LEVELS[lodControl.level] : [-1, 1];
  const ratio = basePixelRatio * fraction;
  if (renderer.getPixelRatio() !== ratio) {
    renderer.setPixelRatio(ratio);
    renderer.setSize(container.clientWidth || 1, container.clientHeight || 1, false);
  }
  for (const entry of lod) {
    const show = entry.full.visible || entry.proxies.some((p) => p.visible);
    entry.full.visible = show && proxyIndex < 0;
    entry.proxies.forEach((p, k) => { p.visible = show && k === proxyIndex; });
  }
  state.lodLevel = moving ? lodControl.level : -1;
  return moving;
}

// Triangles the current level draws (the full mesh at rest).
function drawnTriangles() {
  let n = state.inferredTriangles;
  for (const entry of lod) {
    const shown = [entry.full, ...entry.proxies].find((m) => m.visible);
    if (shown) n += shown.geometry.index.count / 3;
  }
  return lod.length ? n : state.meshTriangles + state.inferredTriangles;
}

async function loadMesh(relative) {
  const gltf = await gltfLoader.loadAsync(withToken('/case/' + relative));
  const group = asWorldGroup(gltf.scene);
  let triangles = 0, inferred = 0;
  gltf.scene.traverse((o) => {
    if (!o.isMesh) return;
    const g = o.geometry;
    const count = (g.index ? g.index.count : g.attributes.position.count) / 3;
    const isInferred = /inferred/i.test((o.material && o.material.name) || '') || /inferred/i.test(o.name || '');
    if (isInferred) { inferred += count; inferredMeshes.push(o); o.material = inferredMaterial; }
    else { triangles += count; o.material = g.attributes.color ? meshMaterial : new THREE.MeshBasicMaterial({ color: 0xb0b0b0 }); }
    o.matrixAutoUpdate = false;
    o.frustumCulled = true;
    g.computeBoundingSphere();
    pickables.push(o);
  });
  meshGroup.add(group);
  group.updateMatrixWorld(true);
  if (triangles > LOD_THRESHOLD) {
    for (const o of [...pickables]) {
      if (inferredMeshes.includes(o) || !o.geometry.index) continue;
      const share = (o.geometry.index.count / 3) / triangles;
      const proxies = LOD_TRIANGLES.map((target) => {
        const proxy = new THREE.Mesh(clusterVertices(o.geometry, target * share), o.material);
        proxy.matrixAutoUpdate = false;
        proxy.matrix.copy(o.matrix);
        proxy.visible = false;
        o.parent.add(proxy);
        return proxy;
      });
      lod.push({ full: o, proxies });
      state.lodTriangles += proxies[0].geometry.index.count / 3;
    }
    group.updateMatrixWorld(true);
  }
  bounds = new THREE.Box3().setFromObject(group);
  floorZ = bounds.min.z;
  state.meshTriangles = triangles;
  state.inferredTriangles = inferred;
  $('inferred-count').textContent = `(${inferred} triangles)`;
}

// --- raw points and segments --------------------------------------------------------------------
let pointsObject = null, pointColors = null, segmentColors = null;

function segmentPalette(label) {
  if (label < 0) return [0.35, 0.35, 0.35];
  const c = new THREE.Color().setHSL(((label * 0.61803398875) % 1 + 1) % 1, 0.75, 0.55);
  return [c.r, c.g, c.b];
}

async function loadPoints() {
  const buffer = await api('/api/points?max=1000000');
  const header = new DataView(buffer, 0, 16);
  const magic = String.fromCharCode(...new Uint8Array(buffer, 0, 4));
  if (magic !== 'LCPT') throw new Error('points: unexpected format');
  const n = header.getUint32(4, true), flags = header.getUint32(8, true);
  const xyz = new Float32Array(buffer, 16, 3 * n);
  const rgbBytes = Math.ceil((3 * n) / 4) * 4;
  const rgb = new Uint8Array(buffer, 16 + 12 * n, 3 * n);
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(xyz, 3));
  pointColors = new THREE.BufferAttribute(rgb, 3, true);
  geometry.setAttribute('color', pointColors);
  if (flags & 1) {
    const labels = new Int32Array(buffer, 16 + 12 * n + rgbBytes, n);
    const colors = new Float32Array(3 * n);
    for (let i = 0; i < n; ++i) colors.set(segmentPalette(labels[i]), 3 * i);
    segmentColors = new THREE.BufferAttribute(colors, 3);
    state.segments = new Set(labels).size;
  }
  geometry.computeBoundingSphere();
  pointsObject = new THREE.Points(geometry, new THREE.PointsMaterial({ size: 2, sizeAttenuation: false, vertexColors: true }));
  pointsGroup.add(pointsObject);
  state.points = n;
  $('show-segments').disabled = !segmentColors;
  if (!segmentColors) $('show-segments').parentElement.title = 'this case has no segment labels';
}

// --- navigation: orbit, walk at eye height ---------------------------------------------------------
let navMode = 'orbit';
const walk = { yaw: 0, pitch: 0, keys: new Set(), last: performance.now(), dragging: false };
const eyeHeight = () => Number($('eye-height').value) || 1.6;

function setWalkPose(x, y, yawRad, pitchRad = 0) {
  walk.yaw = yawRad; walk.pitch = pitchRad;
  camera.position.set(x, y, floorZ + eyeHeight());
  applyWalkOrientation();
}
function applyWalkOrientation() {
  const d = new THREE.Vector3(Math.cos(walk.pitch) * Math.cos(walk.yaw), Math.cos(walk.pitch) * Math.sin(walk.yaw), Math.sin(walk.pitch));
  camera.lookAt(camera.position.clone().add(d));
  requestRender();
}
function setNavMode(mode) {
  navMode = mode;
  document.querySelector(`input[name=nav][value=${mode}]`).checked = true;
  controls.enabled = mode === 'orbit';
  if (mode === 'walk') {
    const d = new THREE.Vector3(); camera.getWorldDirection(d);
    setWalkPose(camera.position.x, camera.position.y, Math.atan2(d.y, d.x), 0);
  } else {
    const d = new THREE.Vector3(); camera.getWorldDirection(d);
    controls.target.copy(camera.position).addScaledVector(d, 2);
    controls.update();
  }
  requestRender();
}
document.querySelectorAll('input[name=nav]').forEach((el) => el.addEventListener('change', () => setNavMode(el.value)));
$('eye-height').addEventListener('change', () => { if (navMode === 'walk') { camera.position.z = floorZ + eyeHeight(); requestRender(); } });
window.addEventListener('keydown', (e) => {
  if (e.target instanceof HTMLInputElement && e.target.type !== 'radio' && e.target.type !== 'checkbox') return;
  walk.keys.add(e.code);
});
window.addEventListener('keyup', (e) => walk.keys.delete(e.code));
renderer.domElement.addEventListener('pointermove', (e) => {
  if (navMode !== 'walk' || !(e.buttons & 1)) return;
  walk.yaw -= e.movementX * 0.004;
  walk.pitch = Math.max(-1.4, Math.min(1.4, walk.pitch - e.movementY * 0.004));
  lastMotion = performance.now();
  applyWalkOrientation();
});
function stepWalk(dt) {
  if (navMode !== 'walk' || walk.keys.size === 0) return false;
  const speed = (walk.keys.has('ShiftLeft') ? 3.0 : 1.2) * dt;
  const f = new THREE.Vector3(Math.cos(walk.yaw), Math.sin(walk.yaw), 0);
  const r = new THREE.Vector3(Math.sin(walk.yaw), -Math.cos(walk.yaw), 0);
  let moved = false;
  if (walk.keys.has('KeyW')) { camera.position.addScaledVector(f, speed); moved = true; }
  if (walk.keys.has('KeyS')) { camera.position.addScaledVector(f, -speed); moved = true; }
  if (walk.keys.has('KeyD')) { camera.position.addScaledVector(r, speed); moved = true; }
  if (walk.keys.has('KeyA')) { camera.position.addScaledVector(r, -speed); moved = true; }
  if (moved) { camera.position.z = floorZ + eyeHeight(); applyWalkOrientation(); lastMotion = performance.now(); }
  return moved;
}

// --- toggles and clipping ----------------------------------------------------------------------
function applyToggles() {
  meshGroup.visible = $('show-mesh').checked;
  for (const m of inferredMeshes) m.visible = $('show-inferred').checked;
  pointsGroup.visible = $('show-points').checked;
  markerGroup.visible = $('show-markers').checked;
  coverageGroup.visible = $('show-coverage').checked;
  if (pointsObject) {
    const useSegments = $('show-segments').checked && segmentColors;
    pointsObject.geometry.setAttribute('color', useSegments ? segmentColors : pointColors);
    if (useSegments) pointsGroup.visible = true;
  }
  requestRender();
}
for (const id of ['show-mesh', 'show-points', 'show-inferred', 'show-segments', 'show-markers', 'show-coverage'])
  $(id).addEventListener('change', applyToggles);

function applyClipping() {
  if (!$('clip-on').checked) { renderer.clippingPlanes = []; $('clip-value').textContent = ''; requestRender(); return; }
  const axis = $('clip-axis').value;
  const t = Number($('clip-pos').value) / 1000;
  const lo = bounds.min[axis], hi = bounds.max[axis];
  const at = lo + t * (hi - lo);
  const n = new THREE.Vector3(axis === 'x' ? 1 : 0, axis === 'y' ? 1 : 0, axis === 'z' ? 1 : 0);
  if (!$('clip-flip').checked) n.negate();  // keep what lies below / before the plane
  clipPlane.normal.copy(n);
  clipPlane.constant = -n.dot(new THREE.Vector3(axis === 'x' ? at : 0, axis === 'y' ? at : 0, axis === 'z' ? at : 0));
  renderer.clippingPlanes = [clipPlane];
  $('clip-value').textContent = `${axis} = ${at.toFixed(2)} m`;
  requestRender();
}
for (const id of ['clip-on', 'clip-axis', 'clip-flip', 'clip-pos']) $(id).addEventListener('input', applyClipping);

// --- coverage: the floor grid of `reconstruct` (one character a cell: s seen, h hidden, u unseen,
// . not floor) as one texture on a plane just above the floor, a texel a cell.
const COVERAGE_RGBA = { u: [214, 39, 40, 150], h: [255, 159, 28, 130] };
async function loadCoverage() {
  const c = await (await fetch(withToken('/case/coverage/floor_coverage.json'))).json();
  const [nx, ny] = c.size;
  const texels = new Uint8Array(nx * ny * 4);
  c.rows.forEach((row, y) => {
    for (let x = 0; x < nx; ++x) {
      const rgba = COVERAGE_RGBA[row[x]];
      if (rgba) texels.set(rgba, 4 * (y * nx + x));
    }
  });
  const texture = new THREE.DataTexture(texels, nx, ny, THREE.RGBAFormat);
  texture.magFilter = THREE.NearestFilter;
  texture.needsUpdate = true;
  const plane = new THREE.Mesh(new THREE.PlaneGeometry(nx * c.cell_m, ny * c.cell_m),
    new THREE.MeshBasicMaterial({ map: texture, transparent: true, depthWrite: false, side: THREE.DoubleSide }));
  plane.position.set(c.origin[0] + nx * c.cell_m / 2, c.origin[1] + ny * c.cell_m / 2, c.floor_z_m + 0.01);
  plane.renderOrder = 1;
  coverageGroup.add(plane);
  state.coverage = { seenShare: c.seen_share, advice: c.advice };
  const a = c.area_m2, all = a.seen + a.hidden + a.unseen;
  $('coverage-share').textContent = `(${Math.round(100 * a.unseen / all)} % unseen, ${Math.round(100 * a.hidden / all)} % hidden)`;
  $('show-coverage').title += '\n' + c.advice.join('\n');
}

// --- picking ------------------------------------------------------------------------------------
const raycaster = new THREE.Raycaster();
// The first visible mesh surface under a canvas pixel (CSS pixels from the canvas' top left),
// honouring the clipping plane; null when the ray misses.
function pickAt(px, py) {
  const rect = renderer.domElement.getBoundingClientRect();
  const ndc = new THREE.Vector2((px / rect.width) * 2 - 1, -(py / rect.height) * 2 + 1);
  raycaster.setFromCamera(ndc, camera);
  // The full meshes, also while the interaction proxy stands in for them.
  const targets = meshGroup.visible ? pickables.filter((o) => (inferredMeshes.includes(o) ? o.visible : true)) : [];
  const hits = raycaster.intersectObjects(targets, false);
  for (const h of hits) {
    if (renderer.clippingPlanes.length && clipPlane.distanceToPoint(h.point) < 0) continue;
    return h.point.clone();
  }
  return null;
}

// --- overlays: labels that follow 3D points ------------------------------------------------------
const tags = [];
function addTag(position, text) {
  const el = document.createElement('div');
  el.className = 'tag';
  el.textContent = text;
  container.appendChild(el);
  tags.push({ el, position: position.clone() });
}
function updateTags() {
  const rect = renderer.domElement.getBoundingClientRect();
  for (const t of tags) {
    const p = t.position.clone().project(camera);
    const visible = p.z < 1 && Math.abs(p.x) <= 1 && Math.abs(p.y) <= 1;
    t.el.style.display = visible ? 'block' : 'none';
    t.el.style.left = `${((p.x + 1) / 2) * rect.width}px`;
    t.el.style.top = `${((1 - p.y) / 2) * rect.height}px`;
  }
}
function line(points, color, dashed = false) {
  const g = new THREE.BufferGeometry().setFromPoints(points);
  const m = dashed ? new THREE.LineDashedMaterial({ color, dashSize: 0.05, gapSize: 0.04, depthTest: false })
    : new THREE.LineBasicMaterial({ color, depthTest: false });
  const l = new THREE.Line(g, m);
  if (dashed) l.computeLineDistances();
  l.renderOrder = 10;
  overlayGroup.add(l);
  return l;
}
function dot(p, color) {
  const s = new THREE.Mesh(new THREE.SphereGeometry(0.012, 12, 8), new THREE.MeshBasicMaterial({ color, depthTest: false }));
  s.position.copy(p);
  s.renderOrder = 11;
  overlayGroup.add(s);
  return s;
}

// --- tools: measure, marker, trajectory ----------------------------------------------------------
let tool = 'none';
let pending = [];
document.querySelectorAll('input[name=tool]').forEach((el) => el.addEventListener('change', () => { tool = el.value; pending = []; }));
const result = (text) => { $('tool-result').textContent = text; };

async function measure(a, b) {
  result('measuring…');
  const m = await api('/api/measure', { a: arr(a), b: arr(b) });
  const pa = vec(m.a.snapped), pb = vec(m.b.snapped);
  line([pa, pb], 0xffe37a);
  dot(pa, 0xffe37a); dot(pb, 0xffe37a);
  const text = `${fmtM(m.distance_m)} ± ${(m.expanded_uncertainty_m * 1000).toFixed(1)} mm`;
  addTag(pa.clone().add(pb).multiplyScalar(0.5), text);
  result(`distance ${fmtM(m.distance_m)}\n± ${(m.expanded_uncertainty_m * 1000).toFixed(1)} mm (k = ${m.coverage_factor}, ~95 %)\n` +
    `a: ${m.a.feature} (${m.a.views} views)\nb: ${m.b.feature} (${m.b.views} views)` +
    (m.a.snapped_to_feature && m.b.snapped_to_feature ? '' :
      '\nwarning: an end is not snapped (no face, edge or corner across the line): the picked point is used as given, and U does not cover it'));
  state.lastMeasurement = m;
  loadSaved().catch((err) => status(`measurements: ${err.message}`));
  requestRender();
  return m;
}

async function trajectory(a, b) {
  result('analysing trajectory…');
  const t = await api('/api/trajectory', { a: arr(a), b: arr(b) });
  const p0 = vec(t.points[0]), p1 = vec(t.points[t.points.length - 1]), d = vec(t.direction);
  line([p0, p1], 0xff5533);
  dot(p0, 0xff5533); dot(p1, 0xff5533);
  const fwdLen = t.forward.hit ? t.forward.distance_m : 3.0;
  const bwdLen = t.backward.hit ? t.backward.distance_m : 3.0;
  const fwdEnd = p1.clone().addScaledVector(d, fwdLen), bwdEnd = p0.clone().addScaledVector(d, -bwdLen);
  line([p1, fwdEnd], 0xff9966, true);
  line([p0, bwdEnd], 0xff9966, true);
  if (t.forward.hit) dot(fwdEnd, 0xffffff);
  if (t.backward.hit) dot(bwdEnd, 0xffffff);
  // Error cone: apex at the exit point, opening forwards with the expanded half-angle.
  const half = THREE.MathUtils.degToRad(Math.max(t.cone_half_angle_deg, 0.01));
  const cone = new THREE.Mesh(new THREE.ConeGeometry(fwdLen * Math.tan(half), fwdLen, 32, 1, true),
    new THREE.MeshBasicMaterial({ color: 0xff5533, transparent: true, opacity: 0.18, side: THREE.DoubleSide, depthWrite: false }));
  cone.quaternion.setFromUnitVectors(new THREE.Vector3(0, -1, 0), d);  // cone apex is at +y
  cone.position.copy(p1).addScaledVector(d, fwdLen / 2);
  overlayGroup.add(cone);
  addTag(p1, `${t.name}: az ${t.horizontal_angle_deg.toFixed(1)}°, el ${t.vertical_angle_deg.toFixed(1)}°`);
  const hit = (h) => (h.hit ? `${fmtM(h.distance_m)} (cone radius ${(h.cone_radius_m * 1000).toFixed(0)} mm)` : 'no surface');
  result(`${t.name}\nhorizontal ${t.horizontal_angle_deg.toFixed(2)}°  vertical ${t.vertical_angle_deg.toFixed(2)}°\n` +
    `cone half-angle ${t.cone_half_angle_deg.toFixed(2)}° (k = 2)\nforward hit: ${hit(t.forward)}\nbackward hit: ${hit(t.backward)}`);
  state.lastTrajectory = t;
  loadSaved().catch((err) => status(`trajectories: ${err.message}`));
  requestRender();
  return t;
}

// Markers: numbered sprites drawn on top, always the same size on screen.
function numberSprite(number) {
  const canvas = document.createElement('canvas');
  canvas.width = canvas.height = 64;
  const g = canvas.getContext('2d');
  g.fillStyle = '#ffd400'; g.strokeStyle = '#000'; g.lineWidth = 4;
  g.beginPath(); g.moveTo(32, 4); g.lineTo(60, 56); g.lineTo(4, 56); g.closePath(); g.fill(); g.stroke();
  g.fillStyle = '#000'; g.font = 'bold 26px DejaVu Sans, sans-serif'; g.textAlign = 'center'; g.textBaseline = 'middle';
  g.fillText(String(number), 32, 40);
  const sprite = new THREE.Sprite(new THREE.SpriteMaterial({ map: new THREE.CanvasTexture(canvas), depthTest: false, sizeAttenuation: false }));
  sprite.scale.set(0.045, 0.045, 1);
  sprite.center.set(0.5, 0.0);
  sprite.renderOrder = 12;
  return sprite;
}

// One entry of the marker, measurement or trajectory lists: its text, what became of it
// (earlier names, withdrawal), and rename / withdraw buttons while it stands.
function listEntry(kind, which, text, object) {
  const li = document.createElement('li');
  const span = document.createElement('span');
  span.textContent = text + (object.previous_names ? ` (was ${object.previous_names.join(', ')})` : '');
  li.appendChild(span);
  if (object.withdrawn) {
    li.classList.add('withdrawn');
    li.title = `withdrawn ${object.withdrawn.at}: ${object.withdrawn.reason}`;
    const why = document.createElement('span');
    why.className = 'why';
    why.textContent = ` withdrawn: ${object.withdrawn.reason}`;
    li.appendChild(why);
    return li;
  }
  for (const [action, label] of [['rename', 'rename'], ['withdraw', 'withdraw']]) {
    const b = document.createElement('button');
    b.type = 'button'; b.className = `edit-${action}`; b.textContent = label;
    b.addEventListener('click', () => {
      const answer = window.prompt(action === 'rename' ? 'New name' : 'Why is it withdrawn? (kept with it and logged)');
      if (answer) editObject(kind, which, action, answer).catch((err) => { result(`error: ${err.message}`); status(err.message); });
    });
    li.appendChild(b);
  }
  return li;
}

// Renames or withdraws a marker, measurement or trajectory: a logged step in the case, as
// `locard evidence rename|withdraw` does; the lists are read again from the case.
async function editObject(kind, which, action, text) {
  const body = action === 'rename' ? { kind, which: String(which), name: text } : { kind, which: String(which), reason: text };
  const r = await api(`/api/evidence/${action}`, body);
  result(`${r.summary} (log line ${r.log_seq})`);
  await Promise.all([loadMarkers(), loadSaved()]);
  return r;
}

async function loadMarkers() {
  const data = await api('/api/markers');
  state.frame = data.case_frame || null;
  state.markers = data.markers.filter((m) => !m.withdrawn);
  state.allMarkers = data.markers;
  markerGroup.clear();
  const list = $('marker-list');
  list.textContent = '';
  $('frame-note').textContent = `coordinates: ${data.frame || 'world frame'}`;
  for (const m of data.markers) {
    if (!m.withdrawn) {
      const s = numberSprite(m.number);
      s.position.copy(vec(m.world));
      markerGroup.add(s);
    }
    const li = listEntry('marker', m.number, `${m.label} ${fmtPoint(m.world)}` + (m.note ? ` — ${m.note}` : ''), m);
    li.value = m.number;
    list.appendChild(li);
  }
  fillWitnessChoices();
  if (state.loaded) status(`${state.meshTriangles.toLocaleString('en')} triangles, ${state.points.toLocaleString('en')} points, ${state.markers.length} markers`);
  requestRender();
  return data.markers;
}

// Measurements and trajectory analyses saved in the case (by the CLI or this viewer): listed,
// and the standing ones drawn, so they survive a reload.
const savedGroup = new THREE.Group();
overlayGroup.add(savedGroup);
async function loadSaved() {
  const [m, t] = await Promise.all([api('/api/measurements'), api('/api/trajectories')]);
  state.savedMeasurements = m.measurements;
  state.savedTrajectories = t.analyses;
  savedGroup.clear();
  const mList = $('measurement-list');
  mList.textContent = '';
  m.measurements.forEach((x, i) => {
    const angle = x.kind === 'plane_angle';
    const value = angle ? `${x.angle_deg.toFixed(2)}° ± ${x.expanded_uncertainty_deg.toFixed(2)}°`
      : `${fmtM(x.distance_m)} ± ${(x.expanded_uncertainty_m * 1000).toFixed(1)} mm`;
    mList.appendChild(listEntry('measurement', `#${i + 1}`, `${x.name}: ${value}`, x));
    if (!x.withdrawn && x.kind === 'point_to_point') {
      const g = new THREE.BufferGeometry().setFromPoints([vec(x.a.snapped), vec(x.b.snapped)]);
      const l = new THREE.Line(g, new THREE.LineBasicMaterial({ color: 0xffe37a, depthTest: false }));
      l.renderOrder = 10;
      savedGroup.add(l);
    }
  });
  const tList = $('trajectory-list');
  tList.textContent = '';
  t.analyses.forEach((x, i) => {
    tList.appendChild(listEntry('trajectory', `#${i + 1}`,
      `${x.name}: az ${x.horizontal_angle_deg.toFixed(1)}°, el ${x.vertical_angle_deg.toFixed(1)}°, cone ${x.cone_half_angle_deg.toFixed(2)}°`, x));
    if (!x.withdrawn) {
      const ends = [x.backward.hit ? x.backward.point : x.points[0], x.forward.hit ? x.forward.point : x.points[x.points.length - 1]];
      const g = new THREE.BufferGeometry().setFromPoints(ends.map(vec));
      const l = new THREE.Line(g, new THREE.LineDashedMaterial({ color: 0xff5533, dashSize: 0.05, gapSize: 0.04, depthTest: false }));
      l.computeLineDistances();
      l.renderOrder = 10;
      savedGroup.add(l);
    }
  });
  requestRender();
}

function askMarker(point) {
  return new Promise((resolve) => {
    const form = $('marker-form');
    $('marker-form-where').textContent = `at ${fmtPoint(arr(point))}`;
    $('marker-label').value = `Item ${state.markers.length + 1}`;
    $('marker-note').value = '';
    form.hidden = false;
    $('marker-label').focus();
    const done = (ok) => { form.hidden = true; form.onsubmit = null; $('marker-cancel').onclick = null; resolve(ok); };
    form.onsubmit = (e) => { e.preventDefault(); done(true); };
    $('marker-cancel').onclick = () => done(false);
  });
}

async function placeMarker(point, label, note = '') {
  const m = await api('/api/markers', { position: arr(point), label, note });
  await loadMarkers();
  result(`marker ${m.number} "${m.label}" saved (log line ${m.log_seq})\n± ${(m.expanded_uncertainty_m * 1000).toFixed(1)} mm`);
  return m;
}

async function onPick(point) {
  if (tool === 'measure' || tool === 'trajectory') {
    pending.push(point);
    dot(point, 0x66ccff);
    requestRender();
    if (pending.length < 2) { result(`first point ${fmtPoint(arr(point))}; click the second`); return; }
    const [a, b] = pending;
    pending = [];
    if (tool === 'measure') await measure(a, b);
    else await trajectory(a, b);
  } else if (tool === 'marker') {
    if (await askMarker(point)) await placeMarker(point, $('marker-label').value, $('marker-note').value);
  }
}

let down = null;
renderer.domElement.addEventListener('pointerdown', (e) => { down = { x: e.clientX, y: e.clientY }; });
renderer.domElement.addEventListener('pointerup', (e) => {
  if (!down || Math.hypot(e.clientX - down.x, e.clientY - down.y) > 4 || tool === 'none') { down = null; return; }
  down = null;
  const rect = renderer.domElement.getBoundingClientRect();
  const p = pickAt(e.clientX - rect.left, e.clientY - rect.top);
  if (!p) { result('nothing under the cursor'); return; }
  onPick(p).catch((err) => { result(`error: ${err.message}`); status(err.message); });
});

// --- witness view ---------------------------------------------------------------------------------
function fillWitnessChoices() {
  for (const id of ['witness-from', 'witness-to']) {
    const sel = $(id);
    const keep = sel.value;
    sel.textContent = '';
    const first = document.createElement('option');
    first.value = ''; first.textContent = id === 'witness-from' ? 'position (x, y below)' : 'heading (below)';
    sel.appendChild(first);
    for (const m of state.markers) {
      const o = document.createElement('option');
      o.value = String(m.number); o.textContent = `${m.number}: ${m.label}`;
      sel.appendChild(o);
    }
    sel.value = keep;
  }
}
// Stands a witness at a marker (by number or label) or at (x, y), eyes at floor + eye height,
// looking at another marker or along a heading (degrees counter-clockwise from +x).
function witnessView({ from, x, y, to, heading, eye } = {}) {
  if (eye) $('eye-height').value = String(eye);
  const find = (key) => state.markers.find((m) => String(m.number) === String(key) || m.label === key);
  let px = x ?? 0, py = y ?? 0;
  if (from !== undefined && from !== '') { const m = find(from); if (!m) throw new Error(`no marker ${from}`); [px, py] = m.world; }
  let yaw = THREE.MathUtils.degToRad(heading ?? 0), pitch = 0;
  navMode = 'walk';
  setNavMode('walk');
  if (to !== undefined && to !== '') {
    const m = find(to); if (!m) throw new Error(`no marker ${to}`);
    const d = vec(m.world).sub(new THREE.Vector3(px, py, floorZ + eyeHeight()));
    yaw = Math.atan2(d.y, d.x); pitch = Math.atan2(d.z, Math.hypot(d.x, d.y));
  }
  setWalkPose(px, py, yaw, pitch);
  status(`witness at (${px.toFixed(2)}, ${py.toFixed(2)}), eyes ${eyeHeight().toFixed(2)} m above the floor`);
}
$('witness-go').addEventListener('click', () => {
  try {
    witnessView({ from: $('witness-from').value, x: Number($('witness-x').value), y: Number($('witness-y').value),
      to: $('witness-to').value, heading: Number($('witness-heading').value) });
  } catch (err) { status(err.message); }
});

// --- simulation playback ---------------------------------------------------------------------------
const sim = { mixer: null, duration: 0, playing: false, object: null, events: [] };
async function loadSimulation(entry) {
  if (sim.object) { simGroup.remove(sim.object); sim.object = null; sim.mixer = null; }
  $('sim-banner').hidden = !entry;
  $('sim-play').disabled = $('sim-time').disabled = !entry;
  $('sim-events').textContent = '';
  state.simulation = null;
  if (!entry) { requestRender(); return; }
  const gltf = await gltfLoader.loadAsync(withToken('/case/' + entry.animation));
  gltf.scene.traverse((o) => {
    if (o.isMesh && o.material && !o.material.isMeshBasicMaterial) {
      const old = o.material;
      o.material = new THREE.MeshBasicMaterial({ color: old.color || 0xcccccc, vertexColors: !!o.geometry.attributes.color, map: old.map || null });
    }
  });
  sim.object = asWorldGroup(gltf.scene);
  simGroup.add(sim.object);
  sim.mixer = new THREE.AnimationMixer(gltf.scene);
  sim.duration = 0;
  for (const clip of gltf.animations) {
    const action = sim.mixer.clipAction(clip);
    action.setLoop(THREE.LoopOnce, 1);
    action.clampWhenFinished = true;
    action.play();
    sim.duration = Math.max(sim.duration, clip.duration);
  }
  sim.mixer.setTime(0);
  if (entry.events) {
    try {
      const ev = await (await fetch(withToken('/case/' + entry.events))).json();
      sim.events = Array.isArray(ev) ? ev : (ev.events || []);
      for (const e of sim.events.slice(0, 50)) {
        const li = document.createElement('li');
        const t = e.time_s ?? e.time ?? e.t;
        li.textContent = `${t !== undefined ? Number(t).toFixed(3) + ' s ' : ''}${e.type || e.kind || ''} ${e.description || e.body || e.name || ''}`.trim();
        $('sim-events').appendChild(li);
      }
    } catch { /* events are optional for playback */ }
  }
  state.simulation = { name: entry.name, clips: gltf.animations.length, duration: sim.duration };
  updateSimClock();
  requestRender();
}
function updateSimClock() {
  if (!sim.mixer) return;
  const t = sim.mixer.time;
  $('sim-clock').textContent = `${t.toFixed(2)} / ${sim.duration.toFixed(2)} s`;
  $('sim-time').value = String(sim.duration > 0 ? Math.round((t / sim.duration) * 1000) : 0);
}
function setSimPlaying(on) {
  if (!sim.mixer) return;
  if (on && sim.mixer.time >= sim.duration - 1e-6) sim.mixer.setTime(0);
  sim.playing = on;
  $('sim-play').textContent = on ? 'Pause' : 'Play';
  requestRender();
}
$('sim-play').addEventListener('click', () => setSimPlaying(!sim.playing));
$('sim-time').addEventListener('input', () => {
  if (!sim.mixer) return;
  sim.mixer.setTime((Number($('sim-time').value) / 1000) * sim.duration);
  updateSimClock();
  requestRender();
});
$('sim-select').addEventListener('change', () => {
  const entry = (state.caseInfo.view.simulations || []).find((s) => s.name === $('sim-select').value);
  loadSimulation(entry || null).catch((err) => status(err.message));
});

// --- render loop, FPS ---------------------------------------------------------------------------
let fpsFrames = 0, fpsStart = performance.now(), lastTime = performance.now();
let benchmark = null;
function frame(now) {
  requestAnimationFrame(frame);
  const dt = Math.min(0.1, (now - lastTime) / 1000);
  lastTime = now;
  if (stepWalk(dt)) needsRender = true;
  if (sim.playing && sim.mixer) {
    sim.mixer.update(dt);
    if (sim.mixer.time >= sim.duration) { sim.mixer.setTime(sim.duration); setSimPlaying(false); }
    updateSimClock();
    needsRender = true;
  }
  if (benchmark) {
    const a = (now - benchmark.start) / 1000 * 0.6;
    camera.position.set(benchmark.center.x + benchmark.radius * Math.cos(a), benchmark.center.y + benchmark.radius * Math.sin(a), benchmark.center.z + benchmark.radius * 0.5);
    camera.lookAt(benchmark.center);
    if (benchmark.lod) lastMotion = now;
    needsRender = true;
  }
  // The frame after motion stops draws the full mesh again.
  {
    const before = state.lodLevel;
    // Frame times count only between frames drawn back to back while moving.
    if (applyLod(now) && needsRender) lodFrameTime(now);
    else lodControl.lastFrame = 0;
    if (state.lodLevel !== before) needsRender = true;
  }
  if (needsRender) {
    needsRender = false;
    renderer.render(scene, camera);
    updateTags();
    fpsFrames += 1;
    state.frames += 1;
    if (benchmark) {
      // Reading one pixel back waits until the GPU has finished the frame, so the count is of
      // frames drawn, not of draw calls queued (which headless Chromium accepts far faster).
      const gl = renderer.getContext();
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, benchmark.pixel);
      benchmark.frames += 1;
    }
  }
  if (now - fpsStart >= 1000) {
    state.fps = (fpsFrames * 1000) / (now - fpsStart);
    // Rendering is on demand: no frame in the last second means nothing moved.
    $('fps').textContent = fpsFrames > 0 ? `${state.fps.toFixed(1)} fps` : 'idle (renders on change)';
    fpsFrames = 0;
    fpsStart = now;
  }
}

// Renders continuously for `seconds` while the camera circles the model; resolves with the
// frames drawn per second (the interactive frame rate).
// With lod, the camera's motion shows the interaction proxy (as a user's drag does); without,
// every frame draws the full mesh.
function runBenchmark(seconds = 5, { lod: useLod = false } = {}) {
  return new Promise((resolve) => {
    const sphere = bounds.getBoundingSphere(new THREE.Sphere());
    lastMotion = -Infinity;
    benchmark = { start: performance.now(), frames: 0, center: sphere.center, radius: sphere.radius * 1.6, pixel: new Uint8Array(4), lod: useLod };
    setTimeout(() => {
      const elapsed = (performance.now() - benchmark.start) / 1000;
      const fps = benchmark.frames / elapsed;
      const level = lodControl.level, ratio = renderer.getPixelRatio(), drawn = drawnTriangles();
      benchmark = null;
      lastMotion = -Infinity;
      requestRender();
      resolve({ fps, frames: Math.round(fps * elapsed), seconds: elapsed, lod: useLod,
        lod_level: useLod ? level : -1, pixel_ratio: ratio,
        triangles_drawn: drawn, triangles: state.meshTriangles + state.inferredTriangles });
    }, seconds * 1000);
  });
}

// Orbit camera looking at a world point from a given world position (tests, scripting).
function lookAt(target, from) {
  setNavMode('orbit');
  camera.position.copy(vec(from));
  controls.target.copy(vec(target));
  controls.update();
  camera.updateMatrixWorld();
  requestRender();
}
// Canvas pixel of a world point (for clicking it).
function toScreen(p) {
  camera.updateMatrixWorld();
  const rect = renderer.domElement.getBoundingClientRect();
  const q = vec(p).project(camera);
  return { x: ((q.x + 1) / 2) * rect.width + rect.left, y: ((1 - q.y) / 2) * rect.height + rect.top };
}

function homeView() {
  const sphere = bounds.getBoundingSphere(new THREE.Sphere());
  const c = sphere.center;
  camera.position.set(c.x + sphere.radius * 0.5, c.y - sphere.radius * 1.3, c.z + sphere.radius * 1.2);
  controls.target.copy(c);
  controls.update();
  camera.near = Math.max(0.01, sphere.radius / 500);
  camera.far = sphere.radius * 20;
  camera.updateProjectionMatrix();
  requestRender();
}

async function main() {
  requestAnimationFrame(frame);
  const info = await api('/api/case');
  state.caseInfo = info;
  const c = info.case || {};
  $('case-title').textContent = c.title || c.name || info.case_dir.split('/').pop();
  document.title = `Locard — ${$('case-title').textContent}`;
  const tasks = [];
  if (info.view.mesh_glb) tasks.push(loadMesh('mesh/mesh.glb'));
  else status('this case has no mesh/mesh.glb');
  if (info.view.cloud) tasks.push(loadPoints().catch((err) => status(`points: ${err.message}`)));
  else $('show-points').disabled = true;
  tasks.push(loadMarkers().then(loadSaved));
  if (info.view.coverage) tasks.push(loadCoverage().catch((err) => status(`coverage: ${err.message}`)));
  else $('show-coverage').disabled = true;
  await Promise.all(tasks);
  for (const s of info.view.simulations || []) {
    if (!s.animation) continue;
    const o = document.createElement('option');
    o.value = s.name; o.textContent = s.name;
    $('sim-select').appendChild(o);
  }
  homeView();
  applyToggles();
  state.loaded = true;
  status(`${state.meshTriangles.toLocaleString('en')} triangles, ${state.points.toLocaleString('en')} points, ${state.markers.length} markers`);
}

window.locardViewer = {
  state, ready: null, pickAt, toScreen, lookAt, measure: (a, b) => measure(vec(a), vec(b)),
  trajectory: (a, b) => trajectory(vec(a), vec(b)), placeMarker: (p, label, note) => placeMarker(vec(p), label, note),
  loadMarkers, loadSaved, editObject, toCaseFrame, witnessView, setNavMode, runBenchmark, homeView,
  setTool: (name) => { document.querySelector(`input[name=tool][value=${name}]`).click(); },
  loadSimulation: (name) => {
    $('sim-select').value = name;
    return loadSimulation((state.caseInfo.view.simulations || []).find((s) => s.name === name) || null);
  },
  playSimulation: (on = true) => setSimPlaying(on),
  simulationTime: () => (sim.mixer ? sim.mixer.time : null),
  requestRender,
};
window.locardViewer.ready = main().catch((err) => { state.error = err.message; status(`error: ${err.message}`); throw err; });
