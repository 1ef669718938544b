// Picking, labels that follow 3D points, and the tools: measure, evidence marker, trajectory;
// the saved objects list (rename, withdraw).
import * as THREE from 'three';
import { $, api, arr, fmtM, status, vec } from './api.js';
import {
  camera, clipPlane, container, fmtPoint, markerGroup, meshGroup, overlayGroup, renderer,
  requestRender, state,
} from './view.js';
import { inferredMeshes, pickables } from './model.js';
import { fillWitnessChoices } from './navigation.js';

// --- picking ------------------------------------------------------------------------------------
export const raycaster = new THREE.Raycaster();
// The first visible mesh surface under a canvas pixel (CSS pixels from the canvas' top left),
// honouring the clipping plane; null when the ray misses.
export function pickAt(px, py) {
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
export const tags = [];
export function addTag(position, text) {
  const el = document.createElement('div');
  el.className = 'tag';
  el.textContent = text;
  container.appendChild(el);
  tags.push({ el, position: position.clone() });
}
export function updateTags() {
  const rect = renderer.domElement.getBoundingClientRect();
  for (const t of tags) {
    const p = t.position.clone().project(camera);
    const visible = p.z < 1 && Math.abs(p.x) <= 1 && Math.abs(p.y) <= 1;
    t.el.style.display = visible ? 'block' : 'none';
    t.el.style.left = `${((p.x + 1) / 2) * rect.width}px`;
    t.el.style.top = `${((1 - p.y) / 2) * rect.height}px`;
  }
}
export function line(points, color, dashed = false) {
  const g = new THREE.BufferGeometry().setFromPoints(points);
  const m = dashed ? new THREE.LineDashedMaterial({ color, dashSize: 0.05, gapSize: 0.04, depthTest: false })
    : new THREE.LineBasicMaterial({ color, depthTest: false });
  const l = new THREE.Line(g, m);
  if (dashed) l.computeLineDistances();
  l.renderOrder = 10;
  overlayGroup.add(l);
  return l;
}
export function dot(p, color) {
  const s = new THREE.Mesh(new THREE.SphereGeometry(0.012, 12, 8), new THREE.MeshBasicMaterial({ color, depthTest: false }));
  s.position.copy(p);
  s.renderOrder = 11;
  overlayGroup.add(s);
  return s;
}

// --- tools: measure, marker, trajectory ----------------------------------------------------------
export let tool = 'none';
export let pending = [];
document.querySelectorAll('input[name=tool]').forEach((el) => el.addEventListener('change', () => { tool = el.value; pending = []; }));
export const result = (text) => { $('tool-result').textContent = text; };

export async function measure(a, b) {
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
      '\nwarning: an end is not snapped (no face, edge or corner across the line): the picked point is used as given, and U holds it only to the mesh there (the fusion\'s truncation band), not to a feature'));
  state.lastMeasurement = m;
  loadSaved().catch((err) => status(`measurements: ${err.message}`));
  requestRender();
  return m;
}

export async function trajectory(a, b) {
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
export function numberSprite(number) {
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
export function listEntry(kind, which, text, object) {
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
export async function editObject(kind, which, action, text) {
  const body = action === 'rename' ? { kind, which: String(which), name: text } : { kind, which: String(which), reason: text };
  const r = await api(`/api/evidence/${action}`, body);
  result(`${r.summary} (log line ${r.log_seq})`);
  await Promise.all([loadMarkers(), loadSaved()]);
  return r;
}

export async function loadMarkers() {
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
export const savedGroup = new THREE.Group();
overlayGroup.add(savedGroup);
export async function loadSaved() {
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

export function askMarker(point) {
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

export async function placeMarker(point, label, note = '') {
  const m = await api('/api/markers', { position: arr(point), label, note });
  await loadMarkers();
  result(`marker ${m.number} "${m.label}" saved (log line ${m.log_seq})\n± ${(m.expanded_uncertainty_m * 1000).toFixed(1)} mm`);
  return m;
}

export async function onPick(point) {
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

export let down = null;
renderer.domElement.addEventListener('pointerdown', (e) => { down = { x: e.clientX, y: e.clientY }; });
renderer.domElement.addEventListener('pointerup', (e) => {
  if (!down || Math.hypot(e.clientX - down.x, e.clientY - down.y) > 4 || tool === 'none') { down = null; return; }
  down = null;
  const rect = renderer.domElement.getBoundingClientRect();
  const p = pickAt(e.clientX - rect.left, e.clientY - rect.top);
  if (!p) { result('nothing under the cursor'); return; }
  onPick(p).catch((err) => { result(`error: ${err.message}`); status(err.message); });
});
