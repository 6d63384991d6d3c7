// laz_perf.js - decode speed of laz-perf (npm laz-perf 0.0.7, WASM, one core), the reference
// for bench/laz.sh: the calls laz2las.js makes (LASZip open, getPoint for every point),
// best of 5. Run: NODE_PATH=DIR/node_modules node bench/laz_perf.js FILE.laz
const fs = require('fs');
const { createLazPerf } = require('laz-perf');
(async () => {
  const buf = fs.readFileSync(process.argv[2]);
  const L = await createLazPerf();
  let best = 1e9, n = 0;
  for (let rep = 0; rep < 5; rep++) {
    const t0 = process.hrtime.bigint();
    const fp = L._malloc(buf.length); L.HEAPU8.set(buf, fp);
    const z = new L.LASZip(); z.open(fp, buf.length);
    n = z.getCount(); const len = z.getPointLength(); const pp = L._malloc(len);
    for (let i = 0; i < n; i++) z.getPoint(pp);
    L._free(pp); z.delete(); L._free(fp);
    const s = Number(process.hrtime.bigint() - t0) / 1e9; if (s < best) best = s;
  }
  console.log(`laz-perf ${process.argv[2]}: ${n} points best ${best.toFixed(4)} s ${(n / best / 1e6).toFixed(2)} M points/s`);
})();
