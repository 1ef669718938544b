// Orbit and walk, layer toggles, the clipping plane, and the witness view.
import * as THREE from 'three';
import { $, status, vec } from './api.js';
import {
  camera, clipPlane, controls, coverageGroup, markerGroup, meshGroup, pointsGroup, renderer,
  requestRender, shared, state,
} from './view.js';
import { inferredMeshes, pointColors, pointsObject, segmentColors } from './model.js';

// --- navigation: orbit, walk at eye height ---------------------------------------------------------
export let navMode = 'orbit';
export const walk = { yaw: 0, pitch: 0, keys: new Set(), last: performance.now(), dragging: false };
export const eyeHeight = () => Number($('eye-height').value) || 1.6;

export function setWalkPose(x, y, yawRad, pitchRad = 0) {
  walk.yaw = yawRad; walk.pitch = pitchRad;
  camera.position.set(x, y, shared.floorZ + eyeHeight());
  applyWalkOrientation();
}
export function applyWalkOrientation() {
  const d = new THREE.Vector3(Math.cos(walk.pitch) * Math.cos(walk.yaw), Math.cos(walk.pitch) * Math.sin(walk.yaw), Math.sin(walk.pitch));
  camera.lookAt(camera.position.clone().add(d));
  requestRender();
}
export function setNavMode(mode) {
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
$('eye-height').addEventListener('change', () => { if (navMode === 'walk') { camera.position.z = shared.floorZ + eyeHeight(); requestRender(); } });
window.addEventListener('keydown', (e) => {
  if (e.target instanceof HTMLInputElement && e.target.type !== 'radio' && e.target.type !== 'checkbox') return;
  walk.keys.add(e.code);
});
window.addEventListener('keyup', (e) => walk.keys.delete(e.code));
renderer.domElement.addEventListener('pointermove', (e) => {
  if (navMode !== 'walk' || !(e.buttons & 1)) return;
  walk.yaw -= e.movementX * 0.004;
  walk.pitch = Math.max(-1.4, Math.min(1.4, walk.pitch - e.movementY * 0.004));
  shared.lastMotion = performance.now();
  applyWalkOrientation();
});
export function stepWalk(dt) {
  if (navMode !== 'walk' || walk.keys.size === 0) return false;
  const speed = (walk.keys.has('ShiftLeft') ? 3.0 : 1.2) * dt;
  const f = new THREE.Vector3(Math.cos(walk.yaw), Math.sin(walk.yaw), 0);
  const r = new THREE.Vector3(Math.sin(walk.yaw), -Math.cos(walk.yaw), 0);
  let moved = false;
  if (walk.keys.has('KeyW')) { camera.position.addScaledVector(f, speed); moved = true; }
  if (walk.keys.has('KeyS')) { camera.position.addScaledVector(f, -speed); moved = true; }
  if (walk.keys.has('KeyD')) { camera.position.addScaledVector(r, speed); moved = true; }
  if (walk.keys.has('KeyA')) { camera.position.addScaledVector(r, -speed); moved = true; }
  if (moved) { camera.position.z = shared.floorZ + eyeHeight(); applyWalkOrientation(); shared.lastMotion = performance.now(); }
  return moved;
}

// --- toggles and clipping ----------------------------------------------------------------------
export function applyToggles() {
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

export function applyClipping() {
  if (!$('clip-on').checked) { renderer.clippingPlanes = []; $('clip-value').textContent = ''; requestRender(); return; }
  const axis = $('clip-axis').value;
  const t = Number($('clip-pos').value) / 1000;
  const lo = shared.bounds.min[axis], hi = shared.bounds.max[axis];
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


// --- witness view ---------------------------------------------------------------------------------
export function fillWitnessChoices() {
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
export function witnessView({ from, x, y, to, heading, eye } = {}) {
  if (eye) $('eye-height').value = String(eye);
  const find = (key) => state.markers.find((m) => String(m.number) === String(key) || m.label === key);
  let px = x ?? 0, py = y ?? 0;
  if (from !== undefined && from !== '') { const m = find(from); if (!m) throw new Error(`no marker ${from}`); [px, py] = m.world; }
  let yaw = THREE.MathUtils.degToRad(heading ?? 0), pitch = 0;
  navMode = 'walk';
  setNavMode('walk');
  if (to !== undefined && to !== '') {
    const m = find(to); if (!m) throw new Error(`no marker ${to}`);
    const d = vec(m.world).sub(new THREE.Vector3(px, py, shared.floorZ + eyeHeight()));
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
