// Time three.js's VRMLLoader on VRML97 files, for benchmarks/bench_vrml_read.py.
//
//   node three_vrml.mjs THREE_DIR REPEATS FILE...
//
// THREE_DIR is the folder of the `three` npm package.  For each file, prints one JSON
// line: {"file": ..., "bytes": ..., "best_s": ..., "cpu_s": ..., "error": ...}; the
// time is the best of REPEATS calls to loader.parse(text, dir) after one warm-up
// call (the file read and UTF-8 decode included, as for our own load()).
import { readFileSync } from "node:fs";
import { dirname, join } from "node:path";
import { pathToFileURL } from "node:url";

const [threeDir, repeatsText, ...files] = process.argv.slice(2);
const repeats = Math.max(1, parseInt(repeatsText, 10) || 1);
const { VRMLLoader } = await import(
  pathToFileURL(join(threeDir, "examples/jsm/loaders/VRMLLoader.js")).href);

for (const file of files) {
  const loader = new VRMLLoader();
  const once = () => loader.parse(readFileSync(file, "utf8"), dirname(file) + "/");
  const out = { file, bytes: readFileSync(file).length };
  try {
    once();
    let best = Infinity, bestCpu = Infinity;
    for (let i = 0; i < repeats; i++) {
      const t0 = process.hrtime.bigint(), c0 = process.cpuUsage();
      once();
      const c = process.cpuUsage(c0);
      best = Math.min(best, Number(process.hrtime.bigint() - t0) / 1e9);
      bestCpu = Math.min(bestCpu, (c.user + c.system) / 1e6);
    }
    out.best_s = best;
    out.cpu_s = bestCpu;
  } catch (e) {
    out.error = String(e && e.message ? e.message : e).slice(0, 300);
  }
  console.log(JSON.stringify(out));
}
