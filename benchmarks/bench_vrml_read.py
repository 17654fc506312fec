#!/usr/bin/env python
"""Read/write speed and memory of the VRML97 codec (``mpeg4fba.vrml``).

    python benchmarks/bench_vrml_read.py [--quick] [--no-peer] [--profile] [--ifs-mb N]

Cases (see benchmarks/README.md):

1. read Choreonoid ``WAIST.wrl`` from the shared corpus (3 MB, one big mesh);
2. read a generated ~50 MB ``IndexedFaceSet`` file, and the peak memory of doing so
   in a fresh subprocess, as a multiple of the numeric payload (numbers x 8 bytes);
3. read a generated scene of 4,096 ``Transform/Shape/Appearance/Material/Box`` nodes;
4. write (``dumps``) the scenes of cases 1 and 3;
5. the lexer's growth curve on blank runs: a small file followed by 1k, 10k and 100k
   blank characters, alone and before a lexing failure (a stray ``'``), and a run of
   alternating comment and blank lines.  Each should grow linearly (until 2026-12 a
   nested quantifier made the time double with every blank).

Each timing is ``time.perf_counter`` around one call, after one warm-up call, best of
3 (best of 1 with ``--quick``).  Reads time ``load(path)`` (the file read and UTF-8
decode included); the peer, PyVRML97, is timed on ``open(path).read()`` plus its
parser's ``parse(text)``, in the same process, if it can be imported.  MB = 10**6
bytes.  A markdown table for the README is printed at the end.
"""
from __future__ import annotations

import argparse
import cProfile
import gc
import io
import json
import os
import platform
import pstats
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))  # benchmark this working tree, not an installed copy

from benchmarks.timing import best_of  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks import generate  # noqa: E402
from mpeg4fba import vrml as mvrml  # noqa: E402

MB = 1e6
WAIST = "data/vrml-corpus/choreonoid+choreonoid/share/model/RIC30/parts/WAIST.wrl"


def shared_dir() -> Path:
    """``$MPEG4FBA_SHARED``, else ``<repo>/../shared`` (may not exist)."""
    env = os.environ.get("MPEG4FBA_SHARED")
    return Path(env) if env else REPO.parent / "shared"


# -- the peer ------------------------------------------------------------------------------

def load_peer():
    """``(parse(path), label)`` for PyVRML97, or ``(None, reason)``."""
    try:
        from importlib.metadata import version
        from vrml.vrml97 import parser as vparser  # PyVRML97 (needs simpleparse)
        p = vparser.buildParser()
        label = f"PyVRML97 {version('PyVRML97')}"
    except Exception as e:  # ImportError, or simpleparse failing to build its tables
        return None, f"PyVRML97 unavailable ({type(e).__name__}: {e}); no peer ratios"

    def parse(path):
        with open(path, encoding="utf-8", errors="surrogateescape") as f:
            text = f.read()
        ok, children, end = p.parse(text)
        if not ok or end != len(text):
            raise RuntimeError(f"PyVRML97 stopped at offset {end} of {len(text)}")
        return children

    return parse, label


THREE_SCRIPT = Path(__file__).resolve().parent / "peers" / "three_vrml.mjs"


def load_three():
    """``(time(paths, reps) -> {path: seconds}, label)`` for three.js's VRMLLoader run by
    ``node``, or ``(None, reason)``.  The ``three`` package is looked for in
    ``$MPEG4FBA_THREE`` (its folder), else wherever ``node`` resolves it from
    ``benchmarks/peers`` (a ``node_modules`` above it, or ``NODE_PATH``)."""
    node = shutil.which("node")
    if node is None:
        return None, "three.js peer skipped: no `node` on PATH"
    three = os.environ.get("MPEG4FBA_THREE")
    if not three:
        r = subprocess.run([node, "-p", "require.resolve('three/package.json')"],
                           cwd=THREE_SCRIPT.parent, capture_output=True, text=True)
        if r.returncode != 0:
            return None, ("three.js peer skipped: the `three` npm package is not installed "
                          "(npm install three, then set MPEG4FBA_THREE to node_modules/three)")
        three = str(Path(r.stdout.strip()).parent)
    try:
        version = json.loads((Path(three) / "package.json").read_text())["version"]
    except (OSError, ValueError, KeyError) as e:
        return None, f"three.js peer skipped: {three} is not the three package ({e})"

    def run(paths, reps):
        r = subprocess.run([node, str(THREE_SCRIPT), three, str(reps)] + [str(p) for p in paths],
                           capture_output=True, text=True)
        out = {}
        for line in r.stdout.splitlines():
            rec = json.loads(line)
            out[rec["file"]] = rec.get("best_s", rec.get("error", "failed"))
        if r.returncode != 0 and not out:
            raise RuntimeError(r.stderr.strip()[-300:])
        return out

    return run, f"three.js {version} VRMLLoader"


# -- memory (a fresh subprocess per measurement) --------------------------------------------

_MEM_CHILD = r"""
import gc, json, resource, sys
sys.path.insert(0, sys.argv[1])
from mpeg4fba import vrml
path, mode, action = sys.argv[2], sys.argv[3], sys.argv[4]
def work():
    scene = vrml.load(path)
    if action == "convert":          # what `mpeg4fba convert` does: read, then write
        vrml.dump(scene, sys.argv[5])
    elif action == "info":           # what `mpeg4fba info` does: read, then sum up
        json.dumps(scene_info(scene))
    return scene
if action == "info":                 # imported before the baseline, like the parser
    from mpeg4fba.cli.info import scene_info
# Build the (lazily made) parser now, so the baseline holds it and the imports.
vrml.loads("#VRML V2.0 utf8\nShape { geometry IndexedFaceSet { coord Coordinate "
           "{ point [ 0 0 0, 1 0 0, 0 1 0 ] } coordIndex [ 0, 1, 2, -1 ] } }")
gc.collect()
def status_kb(key):
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(key + ":"):
                    return int(line.split()[1])
    except OSError:
        pass
    return None
out = {}
if mode == "rss":
    out["maxrss_before_kb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    out["rss_before_kb"] = status_kb("VmRSS")
    try:  # reset VmHWM (this process's peak RSS) to the current RSS
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        out["hwm_reset"] = True
    except OSError:
        out["hwm_reset"] = False
    scene = work()
    out["maxrss_after_kb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    out["hwm_after_kb"] = status_kb("VmHWM")
else:
    import tracemalloc
    tracemalloc.start()
    scene = work()
    out["traced_current"], out["traced_peak"] = tracemalloc.get_traced_memory()
print(json.dumps(out))
"""


def measure_memory(path: Path, payload: int, action: str = "load") -> dict:
    """Peak memory of ``load(path)`` (``action="convert"``: and ``dump`` of the scene to
    a file beside it) in fresh interpreters, over a post-import baseline."""
    res = {}
    out = path.with_name(path.stem + "-converted.wrl")
    for mode in ("rss", "tracemalloc"):
        proc = subprocess.run([sys.executable, "-c", _MEM_CHILD, str(REPO), str(path), mode,
                               action, str(out)], capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"memory subprocess ({mode}) failed:\n{proc.stderr[-2000:]}")
        res.update(json.loads(proc.stdout.strip().splitlines()[-1]))
    # ru_maxrss survives fork+exec on Linux (the child starts with its parent's peak,
    # and subprocess vforks this big process), so where /proc exists the peak is the
    # child's own VmHWM, reset to the current RSS just before the load.
    if res.get("hwm_after_kb") is not None and res.get("rss_before_kb") is not None:
        peak_kb = res["hwm_after_kb"]
        if not res["hwm_reset"]:
            peak_kb = max(peak_kb, res["maxrss_after_kb"])
        res["rss_increase"] = (peak_kb - res["rss_before_kb"]) * 1024
        res["rss_method"] = "VmHWM - VmRSS before"
    else:
        res["rss_increase"] = (res["maxrss_after_kb"] - res["maxrss_before_kb"]) * 1024
        res["rss_method"] = "ru_maxrss after - before"
    res["maxrss_grew"] = res["maxrss_after_kb"] > res["maxrss_before_kb"]
    res["payload"] = payload
    return res


# -- reporting -----------------------------------------------------------------------------

class Results:
    def __init__(self):
        self.rows = []  # dicts for the final table

    def speed(self, case, nbytes, seconds, target=None, peer=None, note="", three=None):
        """One timed case: print its line now and keep it for the table."""
        mbps = nbytes / MB / seconds
        line = f"{case:<40} {nbytes / MB:8.2f} MB {seconds:9.4f} s {mbps:8.2f} MB/s"
        if target is not None:
            line += f"   target >= {target:g} MB/s: {'met' if mbps >= target else 'MISSED'}"
        peer_txt = ratio_txt = "-"
        if isinstance(peer, tuple):
            label, psec = peer
            pmbps = nbytes / MB / psec
            ratio = mbps / pmbps
            line += f"   | {label}: {psec:.4f} s {pmbps:.2f} MB/s, ours/theirs {ratio:.1f}x"
            peer_txt, ratio_txt = f"{pmbps:.2f} MB/s", f"{ratio:.1f}x"
        elif isinstance(peer, str):
            line += f"   | peer: {peer}"
            peer_txt = peer
        three_txt = three_ratio = "-"
        if isinstance(three, tuple):
            tlabel, tsec = three
            tmbps = nbytes / MB / tsec
            line += f"   | {tlabel}: {tsec:.4f} s {tmbps:.2f} MB/s, ours/theirs {mbps / tmbps:.1f}x"
            three_txt, three_ratio = f"{tmbps:.2f} MB/s", f"{mbps / tmbps:.1f}x"
        elif isinstance(three, str):
            line += f"   | three.js: {three}"
            three_txt = three
        if note:
            line += f"   ({note})"
        print(line, flush=True)
        self.rows.append({"case": case, "size": f"{nbytes / MB:.2f}", "time": f"{seconds:.4f}",
                          "result": f"{mbps:.1f} MB/s",
                          "target": f">= {target:g} MB/s" if target is not None else "-",
                          "met": ("yes" if mbps >= target else "**no**") if target is not None
                          else "-",
                          "peer": peer_txt, "ratio": ratio_txt, "mbps": mbps,
                          "three": three_txt, "three_ratio": three_ratio,
                          "target_value": target})

    def skip(self, case, reason):
        print(f"{case:<40} SKIPPED: {reason}", flush=True)
        self.rows.append({"case": case, "size": "-", "time": "-", "result": f"skipped: {reason}",
                          "target": "-", "met": "-", "peer": "-", "ratio": "-",
                          "three": "-", "three_ratio": "-"})

    def other(self, case, nbytes, result, target, met):
        self.rows.append({"case": case, "size": f"{nbytes / MB:.2f}", "time": "-",
                          "result": result, "target": target,
                          "met": "yes" if met else "**no**", "peer": "-", "ratio": "-",
                          "three": "-", "three_ratio": "-"})

    def table(self, peer_label, three_label=None) -> str:
        head = ["Case", "Size (MB)", "Best time (s)", "Result", "Target", "Met",
                f"{peer_label or 'Peer'}", "Ours / peer", three_label or "three.js",
                "Ours / three.js"]
        keys = ["case", "size", "time", "result", "target", "met", "peer", "ratio", "three",
                "three_ratio"]
        lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|"]
        for r in self.rows:
            lines.append("| " + " | ".join(str(r[k]) for k in keys) + " |")
        return "\n".join(lines)


def profile_top(fn, n=10) -> str:
    """The top ``n`` functions of one call of ``fn`` by cumulative, then by own time."""
    prof = cProfile.Profile()
    prof.enable()
    fn()
    prof.disable()
    s = io.StringIO()
    st = pstats.Stats(prof, stream=s)
    st.sort_stats("cumulative").print_stats(n)
    st.sort_stats("tottime").print_stats(n)
    return s.getvalue()


# -- main ------------------------------------------------------------------------------------

def blank_tail(n: int) -> str:
    """``n`` blank characters: spaces, commas, tabs and newlines."""
    return (" ,\t\n" * (n // 4 + 1))[:n]


def comment_tail(n: int) -> str:
    """About ``n`` characters of alternating comment and blank lines."""
    return ("# a comment  \n \t\n" * (n // 17 + 1))[:n]


def try_loads(text: str):
    """``loads(text)``, or the ``VRMLError`` it raises (the failure cases time that)."""
    try:
        return mvrml.loads(text)
    except mvrml.VRMLError as e:
        return e


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="best of 1 instead of best of 3")
    ap.add_argument("--no-peer", action="store_true",
                    help="do not try the peers (PyVRML97, three.js)")
    ap.add_argument("--profile", action="store_true",
                    help="cProfile the read cases that miss their target (top 10 cumulative)")
    ap.add_argument("--ifs-mb", type=float, default=50.0,
                    help="size of the generated IndexedFaceSet file in MB (default 50)")
    args = ap.parse_args(argv)
    reps = 1 if args.quick else 3

    import lark
    print(f"# mpeg4fba.vrml benchmarks: Python {platform.python_version()}, numpy "
          f"{np.__version__}, lark {lark.__version__}, {platform.machine()}, "
          f"best of {reps} after 1 warm-up")

    if args.no_peer:
        peer, peer_label = None, "peer disabled (--no-peer)"
    else:
        peer, peer_label = load_peer()
    if peer is None:
        print(f"# {peer_label}")
        peer_note, peer_label = peer_label, None
    else:
        print(f"# peer: {peer_label} (vrml.vrml97.parser.buildParser().parse(text))")

    if args.no_peer:
        three, three_label = None, "three.js disabled (--no-peer)"
    else:
        three, three_label = load_three()
    print(f"# {'peer: ' if three else ''}{three_label}")
    if three is None:
        three_note, three_label = three_label, None

    res = Results()
    to_profile = []  # (case, fn) that missed their target
    scenes = {}
    read_mbps = {}    # scene name -> read MB/s, for writing's ratio to it

    def read_case(case, path, target, nbytes=None):
        nbytes = nbytes if nbytes is not None else os.path.getsize(path)
        secs, scene = best_of(lambda: mvrml.load(path), reps)
        if peer is not None:
            try:
                psecs, _ = best_of(lambda: peer(path), reps)
                pinfo = (peer_label, psecs)
            except Exception as e:
                pinfo = f"failed ({type(e).__name__}: {str(e)[:80]})"
        else:
            pinfo = None
        tinfo = None
        if three is not None:
            try:
                got = three([path], reps)[str(path)]
                tinfo = (three_label, got) if isinstance(got, float) else f"failed ({got[:80]})"
            except Exception as e:  # node crashing, say: the case still counts for us
                tinfo = f"failed ({type(e).__name__}: {str(e)[:80]})"
        res.speed(case, nbytes, secs, target, pinfo, three=tinfo)
        if target is not None and nbytes / MB / secs < target:
            to_profile.append((case, lambda: mvrml.load(path)))
        gc.collect()
        return scene

    with tempfile.TemporaryDirectory(prefix="mpeg4fba-bench-") as tmp:
        tmp = Path(tmp)

        # 1. Choreonoid WAIST.wrl
        case1 = "read WAIST.wrl (Choreonoid, 1 mesh)"
        shared = shared_dir()
        waist = shared / WAIST
        if waist.is_file():
            scenes["WAIST.wrl"] = read_case(case1, waist, 40)
            read_mbps["WAIST.wrl"] = res.rows[-1]["mbps"]
        else:
            res.skip(case1, f"{waist} not found (set MPEG4FBA_SHARED)")

        # 2. generated IndexedFaceSet
        ifs_path = tmp / "ifs.wrl"
        t0 = time.perf_counter()
        info = generate.write_ifs(ifs_path, int(args.ifs_mb * MB), seed=0)
        print(f"# generated {ifs_path.name}: {info['bytes'] / MB:.2f} MB, {info['points']} "
              f"points, {info['triangles']} triangles, {info['numbers']} numbers "
              f"in {time.perf_counter() - t0:.1f} s", flush=True)
        case2 = f"read IndexedFaceSet ({args.ifs_mb:g} MB generated)"
        scene = read_case(case2, ifs_path, 40)
        del scene
        gc.collect()
        payload = info["numbers"] * 8
        mem = measure_memory(ifs_path, payload)
        rss_x = mem["rss_increase"] / payload
        tm_x = mem["traced_peak"] / payload
        print(f"{'  peak memory of that load':<40} payload {payload / MB:.1f} MB "
              f"({info['numbers']} numbers x 8 B): peak RSS +{mem['rss_increase'] / MB:.1f} MB "
              f"= {rss_x:.2f}x ({mem['rss_method']}), tracemalloc peak "
              f"{mem['traced_peak'] / MB:.1f} MB = {tm_x:.2f}x, retained "
              f"{mem['traced_current'] / MB:.1f} MB = {mem['traced_current'] / payload:.2f}x   "
              f"target < 3x: {'met' if max(rss_x, tm_x) < 3 else 'MISSED'}", flush=True)
        res.other(f"  peak RSS increase, {case2.split(' (')[0][5:]}", info["bytes"],
                  f"{rss_x:.2f}x payload ({mem['rss_increase'] / MB:.0f} MB)", "< 3x", rss_x < 3)
        res.other("  tracemalloc peak, same load", info["bytes"],
                  f"{tm_x:.2f}x payload ({mem['traced_peak'] / MB:.0f} MB)", "< 3x", tm_x < 3)
        for action, label in (("convert", "load + dump (convert)"),
                              ("info", "load + summary (info)")):
            m = measure_memory(ifs_path, payload, action)
            a_rss, a_tm = m["rss_increase"] / payload, m["traced_peak"] / payload
            print(f"{'  peak memory of ' + label:<40} peak RSS +{m['rss_increase'] / MB:.1f} MB "
                  f"= {a_rss:.2f}x, tracemalloc peak {m['traced_peak'] / MB:.1f} MB = {a_tm:.2f}x   "
                  f"target < 4x: {'met' if max(a_rss, a_tm) < 4 else 'MISSED'}", flush=True)
            res.other(f"  peak RSS increase, {label}", info["bytes"],
                      f"{a_rss:.2f}x payload ({m['rss_increase'] / MB:.0f} MB)", "< 4x", a_rss < 4)

        # 3. 4,096 Transforms
        tr_path = tmp / "transforms.wrl"
        generate.write_text(tr_path, generate.transforms_text(4096, seed=0))
        case3 = "read 4,096 Transform/Shape/Box nodes"
        scenes["4,096 Transforms"] = read_case(case3, tr_path, 2)
        read_mbps["4,096 Transforms"] = res.rows[-1]["mbps"]

        # 3b. a CAD-style export: thousands of small meshes, shared materials
        cad_path = tmp / "cad.wrl"
        generate.write_text(cad_path, generate.cad_text(3000, seed=0))
        case3b = "read CAD-style export (3,000 parts)"
        scenes["CAD-style export"] = read_case(case3b, cad_path, None)
        read_mbps["CAD-style export"] = res.rows[-1]["mbps"]

        # 4. writing
        for name, scene in scenes.items():
            secs, text = best_of(lambda: mvrml.dumps(scene), reps)
            out_bytes = len(text.encode("utf-8"))
            ratio = out_bytes / MB / secs / read_mbps[name]
            res.speed(f"write {name} (dumps)", out_bytes, secs,
                      note=f"size = output text; {ratio:.2f}x the reading speed "
                      f"(issue 20: >= 1x) {'met' if ratio >= 1 else 'MISSED'}")

        # 5. the lexer on blank runs
        print("\n# lexer growth on blank runs (ms, best of reps)")
        print(f"{'blanks':>8} {'trailing':>10} {'before stray quote':>19} {'comment/blank lines':>20}")
        for n in (1_000, 10_000, 100_000):
            row = []
            for tail in (blank_tail(n), blank_tail(n) + "'", comment_tail(n)):
                text = "#VRML V2.0 utf8\nGroup {}" + tail
                secs, _ = best_of(lambda: try_loads(text), reps)
                row.append(secs * 1e3)
            print(f"{n:>8,} {row[0]:>10.2f} {row[1]:>19.2f} {row[2]:>20.2f}", flush=True)

        # 6. start-up (issue 20), a few fresh processes; bench_startup.py has more cases
        from benchmarks.bench_startup import GOAL, best as best_process
        print("\n# start-up, best of 3 fresh processes (wall time)")
        bare = best_process([sys.executable, "-c", "pass"], 3, REPO)
        for name, code in (("import mpeg4fba.vrml", ["-c", "import mpeg4fba.vrml"]),
                           ("mpeg4fba --help", ["-m", "mpeg4fba", "--help"]),
                           ("read a one-node file", ["-c", "import mpeg4fba.vrml as v; "
                                                     "v.loads('#VRML V2.0 utf8\\nGroup {}')"])):
            t = best_process([sys.executable] + code, 3, REPO)
            goal = f"   goal < {GOAL} s: {'met' if t < GOAL else 'MISSED'}" if "read" not in name else ""
            print(f"{name:<40} {t:6.3f} s ({t - bare:+.3f} s over bare Python {bare:.3f} s){goal}")
            res.other(f"start-up: {name}", 0, f"{t:.3f} s", f"< {GOAL} s" if goal else "-",
                      t < GOAL or not goal)

        if args.profile:  # inside the with: the generated files still exist
            if not to_profile:
                print("\n# --profile: every read case met its target; nothing profiled")
            for case, fn in to_profile:
                print(f"\n# cProfile of one '{case}' (missed its target)")
                print(profile_top(fn), flush=True)

    if peer is None:
        print(f"# no peer ratios: {peer_note}")
    if three is None:
        print(f"# {three_note}")

    print("\n" + res.table(peer_label, three_label))
    return 0


if __name__ == "__main__":
    sys.exit(main())
