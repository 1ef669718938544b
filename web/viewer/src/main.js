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
//
// Modules by concern: api, view, lod, model, navigation, tools, simulation; this one runs the
// render loop, loads the case and exposes window.locardViewer for tests and scripting.
import * as THREE from 'three';
import { $, api, status, vec } from './api.js';
import {
  camera, controls, renderer, requestRender, scene, shared, state, toCaseFrame,
} from './view.js';
import { applyLod, drawnTriangles, lodControl, lodFrameTime } from './lod.js';
import { loadCoverage, loadMesh, loadPoints } from './model.js';
import { applyToggles, setNavMode, stepWalk, witnessView } from './navigation.js';
import {
  editObject, loadMarkers, loadSaved, measure, pickAt, placeMarker, trajectory, updateTags,
} from './tools.js';
import { loadSimulation, setSimPlaying, sim, updateSimClock } from './simulation.js';

// --- render loop, FPS ---------------------------------------------------------------------------
let fpsFrames = 0, fpsStart = performance.now(), lastTime = performance.now();
let benchmark = null;
function frame(now) {
  requestAnimationFrame(frame);
  const dt = Math.min(0.1, (now - lastTime) / 1000);
  lastTime = now;
  if (stepWalk(dt)) shared.needsRender = true;
  if (sim.playing && sim.mixer) {
    sim.mixer.update(dt);
    if (sim.mixer.time >= sim.duration) { sim.mixer.setTime(sim.duration); setSimPlaying(false); }
    updateSimClock();
    shared.needsRender = true;
  }
  if (benchmark) {
    const a = (now - benchmark.start) / 1000 * 0.6;
    camera.position.set(benchmark.center.x + benchmark.radius * Math.cos(a), benchmark.center.y + benchmark.radius * Math.sin(a), benchmark.center.z + benchmark.radius * 0.5);
    camera.lookAt(benchmark.center);
    if (benchmark.lod) shared.lastMotion = now;
    shared.needsRender = true;
  }
  // The frame after motion stops draws the full mesh again.
  {
    const before = state.lodLevel;
    // Frame times count only between frames drawn back to back while moving.
    if (applyLod(now) && shared.needsRender) lodFrameTime(now);
    else lodControl.lastFrame = 0;
    if (state.lodLevel !== before) shared.needsRender = true;
  }
  if (shared.needsRender) {
    shared.needsRender = false;
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
    const sphere = shared.bounds.getBoundingSphere(new THREE.Sphere());
    shared.lastMotion = -Infinity;
    benchmark = { start: performance.now(), frames: 0, center: sphere.center, radius: sphere.radius * 1.6, pixel: new Uint8Array(4), lod: useLod };
    setTimeout(() => {
      const elapsed = (performance.now() - benchmark.start) / 1000;
      const fps = benchmark.frames / elapsed;
      const level = lodControl.level, ratio = renderer.getPixelRatio(), drawn = drawnTriangles();
      benchmark = null;
      shared.lastMotion = -Infinity;
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
  const sphere = shared.bounds.getBoundingSphere(new THREE.Sphere());
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
