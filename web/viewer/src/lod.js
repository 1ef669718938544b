// Level of detail while the camera moves (see the constants' comment).
import * as THREE from 'three';
import { container, renderer, shared, state } from './view.js';

// Level of detail while the camera moves. A mesh above LOD_THRESHOLD triangles gets proxies
// of about LOD_TRIANGLES[k] triangles by vertex clustering (Rossignac & Borrel 1993: the
// vertices in each cell of a uniform grid merge into their mean, triangles that collapse are
// dropped). While the view changes, the viewer draws the level of LOD_LEVELS that holds
// TARGET_FPS on this machine (measured frame by frame: a fast GPU keeps the full mesh, software
// WebGL steps down to coarser proxies and fewer pixels); as soon as the view rests
// (MOTION_REST_MS) the full mesh returns at full resolution, so every still image, screenshot
// and pick uses the full mesh.
export const LOD_THRESHOLD = 400000, LOD_TRIANGLES = [120000, 30000, 8000, 2000], MOTION_REST_MS = 250;
// [proxy index (-1: the full mesh), fraction of the pixel ratio], finest first. The last level
// is for software WebGL on a small CPU, where most of a frame is fixed cost: on the 2-core CI
// machine the 8k proxy at 1/4 ran 28-38 fps from one run to another, the 2k one at 1/6 37.6.
export const LOD_LEVELS = [[-1, 1], [0, 1 / 2], [1, 1 / 2], [1, 1 / 3], [2, 1 / 4], [3, 1 / 6]];
export const TARGET_FPS = 30;
export const lod = [];  // { full, proxies: [mesh per LOD_TRIANGLES entry] }
shared.lastMotion = -Infinity;
// The adaptive controller: the level used while moving, decided on the mean frame time of
// windows of LOD_WINDOW frames drawn back to back (a single slow frame, a garbage collection,
// moves nothing): coarser when a window is over the budget by 10 %, finer when it is under 40 %
// of it (the finer level costing up to twice as much still fits), never finer within 3 s of
// having had to go coarser (no oscillation).
export const LOD_WINDOW = 10;
export const lodControl = { level: 1, sumMs: 0, frames: 0, lastFrame: 0, holdUntil: 0, skip: 3 };
export function lodFrameTime(now) {
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

export function clusterVertices(geometry, targetTriangles) {
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
export const basePixelRatio = Math.min(window.devicePixelRatio, 1.5);
export function applyLod(now) {
  const moving = lod.length > 0 && now - shared.lastMotion < MOTION_REST_MS;
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
export function drawnTriangles() {
  let n = state.inferredTriangles;
  for (const entry of lod) {
    const shown = [entry.full, ...entry.proxies].find((m) => m.visible);
    if (shown) n += shown.geometry.index.count / 3;
  }
  return lod.length ? n : state.meshTriangles + state.inferredTriangles;
}
