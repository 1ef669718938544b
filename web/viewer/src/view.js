// Renderer, scene, camera and the groups everything is drawn into; the state exposed for tests;
// the case frame. `shared` holds what several modules change: the model's bounds and floor,
// whether a frame is due, when the view last moved.
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { $ } from './api.js';

// --- renderer, scene, camera -----------------------------------------------------------------
export const container = $('viewport');
export const renderer = new THREE.WebGLRenderer({ antialias: false, powerPreference: 'high-performance' });
renderer.setPixelRatio(Math.min(window.devicePixelRatio, 1.5));  // see applyLod
renderer.shadowMap.enabled = false;
container.appendChild(renderer.domElement);
export const scene = new THREE.Scene();
scene.background = new THREE.Color(0x1d2026);
export const camera = new THREE.PerspectiveCamera(60, 1, 0.02, 200);
camera.up.set(0, 0, 1);
camera.position.set(0, -6, 4);
export const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;
controls.screenSpacePanning = true;

export const root = new THREE.Group();  // world frame, z up
scene.add(root);
export const meshGroup = new THREE.Group();
export const pointsGroup = new THREE.Group();
export const overlayGroup = new THREE.Group();  // measurements, trajectories
export const markerGroup = new THREE.Group();
export const simGroup = new THREE.Group();
export const coverageGroup = new THREE.Group();  // the floor the scan did not observe
root.add(meshGroup, pointsGroup, overlayGroup, markerGroup, simGroup, coverageGroup);
coverageGroup.visible = false;
pointsGroup.visible = false;

export const clipPlane = new THREE.Plane(new THREE.Vector3(0, 0, -1), 0);
// What several modules change (see the header).
export const shared = { bounds: null, floorZ: 0, needsRender: true, lastMotion: -Infinity };
shared.bounds = new THREE.Box3(new THREE.Vector3(-3, -3, 0), new THREE.Vector3(3, 3, 3));
shared.floorZ = 0;

shared.needsRender = true;
export const requestRender = () => { shared.needsRender = true; };
controls.addEventListener('change', () => { shared.lastMotion = performance.now(); requestRender(); });

export function resize() {
  const w = container.clientWidth || 1, h = container.clientHeight || 1;
  renderer.setSize(w, h, false);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
  requestRender();
}
window.addEventListener('resize', resize);
resize();

// --- state exposed for tests and scripting -------------------------------------------------------
export const state = {
  caseInfo: null, meshTriangles: 0, inferredTriangles: 0, points: 0, markers: [],
  lastMeasurement: null, lastTrajectory: null, fps: 0, frames: 0, loaded: false, error: null,
  simulation: null, lodTriangles: 0, lodLevel: -1,
  frame: null, savedMeasurements: [], savedTrajectories: [],
};

// --- the case frame (`locard marker frame`): coordinates are shown as the CLI and report print
// them; the API speaks world coordinates, the frame turns them into the case's.
export function toCaseFrame(p) {
  const f = state.frame;
  const a = Array.isArray(p) ? p : [p.x, p.y, p.z];
  if (!f) return a;
  const d = [a[0] - f.origin[0], a[1] - f.origin[1], a[2] - f.origin[2]];
  const dot = (u) => u[0] * d[0] + u[1] * d[1] + u[2] * d[2];
  return [dot(f.x_axis), dot(f.y_axis), dot(f.z_axis)];
}
export const fmtPoint = (p) => `(${toCaseFrame(p).map((v) => v.toFixed(3)).join(', ')})`;
