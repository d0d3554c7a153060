// Runs mapbox/martini (RTIN, npm @mapbox/martini) on the terrains and thresholds written by
// varmesh_terrain_bench, and measures martini's true vertical error over every original sample.
// usage: node martini_compare.mjs MANIFEST.json   (run from a folder where @mapbox/martini is installed)
import fs from 'fs';
import { createRequire } from 'module';
import path from 'path';

const require = createRequire(path.resolve('package.json'));
const Martini = (await import(require.resolve('@mapbox/martini'))).default;

// Median of back-to-back runs: at least `runs`, and for short ones more, until about 200 ms have been
// timed (at most 401), the rule terrain_compare.cpp uses for varmesh's extraction.
function median(runs, f) {
  const t = [];
  let out;
  let total = 0;
  while (t.length < runs || (total < 200 && t.length < 401)) {
    const s = process.hrtime.bigint();
    out = f();
    t.push(Number(process.hrtime.bigint() - s) / 1e6);
    total += t[t.length - 1];
  }
  t.sort((a, b) => a - b);
  return [t[Math.floor(t.length / 2)], out];
}

// Largest |sample - mesh| over the original width x height samples (barycentric rasterization).
function maxError(mesh, z, size, width, height) {
  const v = mesh.vertices, tri = mesh.triangles;
  let worst = 0;
  for (let t = 0; t < tri.length; t += 3) {
    const ax = v[2 * tri[t]], ay = v[2 * tri[t] + 1], bx = v[2 * tri[t + 1]], by = v[2 * tri[t + 1] + 1];
    const cx = v[2 * tri[t + 2]], cy = v[2 * tri[t + 2] + 1];
    const za = z[ay * size + ax], zb = z[by * size + bx], zc = z[cy * size + cx];
    const det = (bx - ax) * (cy - ay) - (cx - ax) * (by - ay);
    if (det === 0) continue;
    const x0 = Math.min(ax, bx, cx), x1 = Math.min(Math.max(ax, bx, cx), width - 1);
    const y0 = Math.min(ay, by, cy), y1 = Math.min(Math.max(ay, by, cy), height - 1);
    for (let y = y0; y <= y1; y++) {
      for (let x = x0; x <= x1; x++) {
        const l1 = ((x - ax) * (cy - ay) - (cx - ax) * (y - ay)) / det;
        const l2 = ((bx - ax) * (y - ay) - (x - ax) * (by - ay)) / det;
        const l0 = 1 - l1 - l2;
        if (l0 < -1e-9 || l1 < -1e-9 || l2 < -1e-9) continue;
        const e = Math.abs(z[y * size + x] - (l0 * za + l1 * zb + l2 * zc));
        if (e > worst) worst = e;
      }
    }
  }
  return worst;
}

const cases = JSON.parse(fs.readFileSync(process.argv[2], 'utf8'));
console.log('terrain            init ms  error-map ms | threshold  triangles   mesh ms   Mtri/s   max err  err/threshold');
for (const c of cases) {
  const buf = fs.readFileSync(c.file);
  const z = new Float32Array(buf.buffer, buf.byteOffset, c.size * c.size);
  const [initMs, martini] = median(9, () => new Martini(c.size));
  const [tileMs, tile] = median(9, () => martini.createTile(z));
  for (const thr of c.thresholds) {
    const [meshMs, mesh] = median(9, () => tile.getMesh(thr));
    const n = mesh.triangles.length / 3;
    const err = maxError(mesh, z, c.size, c.width, c.height);
    console.log(`${c.name.padEnd(18)} ${initMs.toFixed(1).padStart(8)} ${tileMs.toFixed(1).padStart(13)} | ` +
      `${thr.toPrecision(4).padStart(9)} ${String(n).padStart(10)} ${meshMs.toFixed(2).padStart(9)} ` +
      `${(n / meshMs / 1000).toFixed(1).padStart(8)} ${err.toPrecision(4).padStart(9)} ${(err / thr).toFixed(2).padStart(14)}`);
  }
}
