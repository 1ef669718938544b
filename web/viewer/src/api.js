// The server's API and small helpers: every request carries the run's token.
import * as THREE from 'three';

export const token = new URLSearchParams(window.location.search).get('token') || '';
export const withToken = (url) => url + (url.includes('?') ? '&' : '?') + 'token=' + encodeURIComponent(token);
export const $ = (id) => document.getElementById(id);

export async function api(path, body) {
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

export const status = (text) => { $('status').textContent = text; };
export const vec = (a) => new THREE.Vector3(a[0], a[1], a[2]);
export const arr = (v) => [v.x, v.y, v.z];
export const fmtM = (m) => `${m.toFixed(3)} m`;
