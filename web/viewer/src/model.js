// What the case holds: the mesh (glTF, y-up turned z-up), the raw points and segments, and the
// floor the scan did not observe.
import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { $, api, withToken } from './api.js';
import { coverageGroup, meshGroup, pointsGroup, shared, state } from './view.js';
import { LOD_THRESHOLD, LOD_TRIANGLES, clusterVertices, lod } from './lod.js';

// --- mesh ------------------------------------------------------------------------------------
export const gltfLoader = new GLTFLoader();
export const meshMaterial = new THREE.MeshBasicMaterial({ vertexColors: true });
export const inferredMaterial = new THREE.MeshBasicMaterial({ color: 0xff33cc, transparent: true, opacity: 0.75 });
export const inferredMeshes = [];
export const pickables = [];

export function asWorldGroup(gltfScene) {
  const g = new THREE.Group();
  g.rotation.x = Math.PI / 2;  // glTF y-up -> world z-up: (x, y, z) -> (x, -z, y)
  g.add(gltfScene);
  return g;
}


export async function loadMesh(relative) {
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
  shared.bounds = new THREE.Box3().setFromObject(group);
  shared.floorZ = shared.bounds.min.z;
  state.meshTriangles = triangles;
  state.inferredTriangles = inferred;
  $('inferred-count').textContent = `(${inferred} triangles)`;
}

// --- raw points and segments --------------------------------------------------------------------
export let pointsObject = null, pointColors = null, segmentColors = null;

export function segmentPalette(label) {
  if (label < 0) return [0.35, 0.35, 0.35];
  const c = new THREE.Color().setHSL(((label * 0.61803398875) % 1 + 1) % 1, 0.75, 0.55);
  return [c.r, c.g, c.b];
}

export async function loadPoints() {
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


// --- coverage: the floor grid of `reconstruct` (one character a cell: s seen, h hidden, u unseen,
// . not floor) as one texture on a plane just above the floor, a texel a cell.
export const COVERAGE_RGBA = { u: [214, 39, 40, 150], h: [255, 159, 28, 130] };
export async function loadCoverage() {
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
