// Bundles the viewer: src/main.js (+ three.js) -> OUT/app.js, and copies index.html and
// app.css beside it. Usage: node build.mjs [--node-modules DIR] [--out DIR]
// (defaults: ./node_modules and ./dist). Run by CMake at build time; no network needed.
import { fileURLToPath, pathToFileURL } from 'node:url';
import path from 'node:path';
import fs from 'node:fs';

const here = path.dirname(fileURLToPath(import.meta.url));
const args = process.argv.slice(2);
const option = (name, fallback) => {
  const i = args.indexOf(name);
  return i >= 0 && i + 1 < args.length ? path.resolve(args[i + 1]) : fallback;
};
const nodeModules = option('--node-modules', path.join(here, 'node_modules'));
const out = option('--out', path.join(here, 'dist'));

const esbuild = await import(pathToFileURL(path.join(nodeModules, 'esbuild', 'lib', 'main.js')).href);
fs.mkdirSync(out, { recursive: true });
await esbuild.build({
  entryPoints: [path.join(here, 'src', 'main.js')],
  bundle: true,
  format: 'esm',
  minify: true,
  sourcemap: false,
  target: ['es2020'],
  nodePaths: [nodeModules],
  outfile: path.join(out, 'app.js'),
  logLevel: 'warning',
  legalComments: 'eof',
});
for (const name of ['index.html', 'app.css'])
  fs.copyFileSync(path.join(here, 'src', name), path.join(out, name));
console.log(`viewer bundle: ${out}`);
