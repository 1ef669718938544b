// Interop check: an independent E57 reader reads back what Locard writes.
//
// For each source E57 file: `locard convert SRC src.ply` (E57 -> PLY), `locard convert src.ply
// ours.e57` (PLY -> E57), `locard convert ours.e57 back.ply --ascii` (Locard reading its own
// file). web-e57 (npm; the pure-Rust `e57` crate built to WebAssembly, not our code) then
// converts both SRC and ours.e57 to XYZ text ("x y z r g b" per point). Required:
//  - web-e57 reads ours.e57 with the same number of points as SRC, and the same colours;
//  - its positions equal SRC's to float rounding (1e-6 m), and equal Locard's own reading of
//    ours.e57 exactly (same single-precision values).
//
//   node check.mjs --locard build/release/locard --node-modules DIR/node_modules --work DIR
//        --source a.e57 [--source b.e57 ...]
import { execFileSync } from "node:child_process";
import { mkdirSync, readFileSync, rmSync } from "node:fs";
import { join } from "node:path";
import { pathToFileURL } from "node:url";

function parseArgs(argv) {
  const args = { sources: [] };
  for (let i = 0; i < argv.length; i += 2) {
    const [key, value] = [argv[i], argv[i + 1]];
    if (value === undefined) throw new Error(`missing value after ${key}`);
    if (key === "--source") args.sources.push(value);
    else args[key.replace(/^--/, "").replace(/-/g, "_")] = value;
  }
  for (const k of ["locard", "node_modules", "work"])
    if (!args[k]) throw new Error(`--${k.replace(/_/g, "-")} is required`);
  if (args.sources.length === 0) throw new Error("at least one --source is required");
  return args;
}

// web-e57 is a wasm-bindgen "bundler" package: its module imports the .wasm file, which Node
// only does behind a flag. Instantiating the .wasm here with the glue's exports needs none.
async function loadWebE57(nodeModules) {
  const dir = join(nodeModules, "web-e57");
  const glue = await import(pathToFileURL(join(dir, "e57_bg.js")).href);
  const { instance } = await WebAssembly.instantiate(readFileSync(join(dir, "e57_bg.wasm")), {
    "./e57_bg.js": glue,
  });
  glue.__wbg_set_wasm(instance.exports);
  return (path) => parseXyz(glue.convertE57(new Uint8Array(readFileSync(path)), "XYZ"));
}

// "x y z [r g b]" lines -> { xyz: Float64Array, rgb: Uint8Array | null, count }
function parseXyz(text) {
  const lines = text.split("\n").filter((l) => l.trim() !== "");
  const count = lines.length;
  const xyz = new Float64Array(count * 3);
  const hasRgb = count > 0 && lines[0].trim().split(/\s+/).length >= 6;
  const rgb = hasRgb ? new Uint8Array(count * 3) : null;
  lines.forEach((line, i) => {
    const v = line.trim().split(/\s+/).map(Number);
    for (let k = 0; k < 3; ++k) xyz[3 * i + k] = v[k];
    if (hasRgb) for (let k = 0; k < 3; ++k) rgb[3 * i + k] = v[3 + k];
  });
  return { xyz, rgb, count };
}

// Locard's ascii PLY: x y z and red green blue wherever the header puts them.
function readAsciiPly(path) {
  const text = readFileSync(path, "utf8");
  const end = text.indexOf("end_header\n");
  const header = text.slice(0, end).split("\n");
  const names = [];
  let inVertex = false;
  let count = 0;
  for (const line of header) {
    const w = line.trim().split(/\s+/);
    if (w[0] === "element") {
      inVertex = w[1] === "vertex";
      if (inVertex) count = Number(w[2]);
    } else if (w[0] === "property" && inVertex) names.push(w[w.length - 1]);
  }
  const col = (n) => names.indexOf(n);
  const body = text.slice(end + "end_header\n".length).split("\n").slice(0, count);
  const xyz = new Float64Array(count * 3);
  const hasRgb = col("red") >= 0;
  const rgb = hasRgb ? new Uint8Array(count * 3) : null;
  body.forEach((line, i) => {
    const v = line.trim().split(/\s+/).map(Number);
    ["x", "y", "z"].forEach((n, k) => (xyz[3 * i + k] = v[col(n)]));
    if (hasRgb) ["red", "green", "blue"].forEach((n, k) => (rgb[3 * i + k] = v[col(n)]));
  });
  return { xyz, rgb, count };
}

function check(condition, message) {
  if (!condition) throw new Error(message);
}

function compare(name, a, b, { tolerance, exactFloat }) {
  check(a.count === b.count, `${name}: ${a.count} points vs ${b.count}`);
  check(!!a.rgb === !!b.rgb, `${name}: colour on one side only`);
  let worst = 0;
  for (let i = 0; i < a.xyz.length; ++i) {
    const [p, q] = exactFloat ? [Math.fround(a.xyz[i]), Math.fround(b.xyz[i])] : [a.xyz[i], b.xyz[i]];
    worst = Math.max(worst, Math.abs(p - q));
  }
  check(worst <= tolerance, `${name}: positions differ by up to ${worst} m (allowed ${tolerance})`);
  let colourDiffs = 0;
  if (a.rgb) for (let i = 0; i < a.rgb.length; ++i) colourDiffs += a.rgb[i] !== b.rgb[i];
  check(colourDiffs === 0, `${name}: ${colourDiffs} colour channels differ`);
  return worst;
}

async function main() {
  const args = parseArgs(process.argv.slice(2));
  const webE57 = await loadWebE57(args.node_modules);
  rmSync(args.work, { recursive: true, force: true });
  mkdirSync(args.work, { recursive: true });
  const locard = (...a) => execFileSync(args.locard, ["--quiet", ...a], { stdio: "inherit" });
  for (const [i, source] of args.sources.entries()) {
    const dir = join(args.work, String(i));
    mkdirSync(dir);
    const [ply, ours, back] = ["src.ply", "ours.e57", "back.ply"].map((f) => join(dir, f));
    locard("convert", source, ply);
    locard("convert", ply, ours);
    locard("convert", ours, back, "--ascii");
    const original = webE57(source);
    const written = webE57(ours);
    check(written.count > 0, `${source}: web-e57 read no points from ours.e57`);
    const worst = compare(`web-e57(${source}) vs web-e57(ours.e57)`, original, written,
                          { tolerance: 1e-6, exactFloat: false });
    compare(`web-e57(ours.e57) vs locard(ours.e57)`, written, readAsciiPly(back),
            { tolerance: 0, exactFloat: true });
    console.log(`${source}: web-e57 reads ${written.count} points${written.rgb ? " with colour" : ""} ` +
                `from Locard's E57 (positions within ${worst.toExponential(2)} m of the source)`);
  }
}

main().catch((e) => {
  console.error(`e57 interop: ${e.message}`);
  process.exit(1);
});
