// Playback of the case's illustrative simulations.
import * as THREE from 'three';
import { $, status, withToken } from './api.js';
import { requestRender, simGroup, state } from './view.js';
import { asWorldGroup, gltfLoader } from './model.js';

// --- simulation playback ---------------------------------------------------------------------------
export const sim = { mixer: null, duration: 0, playing: false, object: null, events: [] };
export async function loadSimulation(entry) {
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
export function updateSimClock() {
  if (!sim.mixer) return;
  const t = sim.mixer.time;
  $('sim-clock').textContent = `${t.toFixed(2)} / ${sim.duration.toFixed(2)} s`;
  $('sim-time').value = String(sim.duration > 0 ? Math.round((t / sim.duration) * 1000) : 0);
}
export function setSimPlaying(on) {
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
