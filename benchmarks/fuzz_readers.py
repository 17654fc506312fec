#!/usr/bin/env python
"""The long fuzzing run of every file reader (issue 21).

    python benchmarks/fuzz_readers.py [--count N] [--time-limit S] [--readers a,b]
                                      [--jobs J] [--cpu 1.0] [--start 0] [--no-shared]
                                      [--keep DIR]

Inputs come from ``tests/fuzz/harness.py`` (seeds, mutations, judging): input ``i`` of
a reader is the same bytes on every run, so a failure is reproduced from its reader
and number (``harness.locate(reader, i)``).  Each input is read in a worker process
(``--jobs`` of them) under:

* a CPU limit per input (``--cpu`` seconds, default 1): past it the read is stopped
  and counted as a hang (a timer signal; a hard RLIMIT_CPU a few seconds later ends a
  worker stuck in C code, which is then restarted);
* an address-space cap of the worker's size before the input plus 5x the input plus
  512 MB: an allocation past it is a MemoryError, counted as a memory blow-up;
* the peak resident memory of each read, over the worker's resident memory before it
  (Linux: VmHWM reset through /proc/self/clear_refs): a read that grows it by more
  than 5x the input plus 32 MB (the interpreter's working set for any read) counts as
  a memory blow-up too (for gzip input, 5x what it inflates to).

It prints a table per reader: inputs, the reader's own errors, accepted, other
exceptions (grouped by type and the frame that raised them), hangs and memory
blow-ups, with the worst CPU time and peak memory.  Each other exception, hang or
blow-up is minimised (chunks removed while it still fails the same way) and kept in
``--keep`` (default ``tests/fuzz/regressions/<reader>/``), which the test suite reads
again.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter, defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
for p in (str(REPO), str(REPO / "tests")):
    if p not in sys.path:
        sys.path.insert(0, p)

MB = 1 << 20


# -- the worker ---------------------------------------------------------------------------------

def _status_kb(key: str):
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(key + ":"):
                    return int(line.split()[1])
    except OSError:
        pass
    return None


class _Hang(BaseException):
    """Raised by the CPU timer; a BaseException so no reader's except catches it."""


def _on_timer(signum, frame):
    raise _Hang()


def worker(cpu_limit: float, shared: bool) -> None:
    """Read jobs ("reader seed" lines) from stdin, answer one JSON line each."""
    from fuzz import harness as h
    __import__("numpy")    # loaded before the baseline, as every reader uses it
    pools = {}
    folder = Path(tempfile.mkdtemp(prefix="mpeg4fba-fuzz-"))
    signal.signal(signal.SIGPROF, _on_timer)
    hard = resource.getrlimit(resource.RLIMIT_AS)[1]
    for line in sys.stdin:
        name, seed = line.split()
        seed = int(seed)
        reader = h.READERS[name]
        if name not in pools:
            pools[name] = h.seeds(reader, shared)
            h.run_input(reader, pools[name][0][1], folder)       # imports before the baseline
        data = h.make_input(reader, pools[name], seed)
        try:
            with open("/proc/self/clear_refs", "w") as f:
                f.write("5")
        except OSError:
            pass
        rss0 = _status_kb("VmRSS") or 0
        size_kb = _status_kb("VmSize")
        if size_kb is not None:
            cap = size_kb * 1024 + 5 * len(data) + 512 * MB
            resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
        used = resource.getrusage(resource.RUSAGE_SELF)
        cpu0 = used.ru_utime + used.ru_stime
        resource.setrlimit(resource.RLIMIT_CPU, (int(cpu0 + cpu_limit + 5),
                                                 resource.getrlimit(resource.RLIMIT_CPU)[1]))
        signal.setitimer(signal.ITIMER_PROF, cpu_limit)
        try:
            kind, detail = h.run_input(reader, data, folder)
        except _Hang:
            kind, detail = "hang", f"over {cpu_limit:g} s of CPU"
        except MemoryError:
            kind, detail = "memory", "MemoryError under the address-space cap"
        finally:
            signal.setitimer(signal.ITIMER_PROF, 0)
            resource.setrlimit(resource.RLIMIT_AS, (hard, hard))
        used = resource.getrusage(resource.RUSAGE_SELF)
        cpu = used.ru_utime + used.ru_stime - cpu0
        peak = max(0, (_status_kb("VmHWM") or 0) - rss0) * 1024
        size = h.payload(reader, data)
        if kind in ("accepted", "error") and peak > 5 * size + 32 * MB:
            kind, detail = "memory", f"peak RSS +{peak / MB:.0f} MB for {size} bytes"
        print(json.dumps({"reader": name, "seed": seed, "kind": kind, "detail": detail,
                          "cpu": cpu, "peak": peak, "size": size}), flush=True)


# -- the parent ---------------------------------------------------------------------------------

class Worker:
    def __init__(self, cpu: float, shared: bool):
        cmd = [sys.executable, __file__, "--worker", "--cpu", str(cpu)]
        if not shared:
            cmd.append("--no-shared")
        # one BLAS thread: the CPU limit is the process's CPU time, and idle BLAS threads
        # spinning after a matrix product would be charged to whatever input came next
        env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
                   MKL_NUM_THREADS="1")
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     text=True, bufsize=1, env=env)
        self.job = None

    def send(self, name: str, seed: int) -> None:
        self.job = (name, seed)
        self.proc.stdin.write(f"{name} {seed}\n")
        self.proc.stdin.flush()

    def receive(self):
        line = self.proc.stdout.readline()
        if not line:                      # died: RLIMIT_CPU, a crash, the OOM killer
            self.proc.wait()
            return None
        return json.loads(line)

    def close(self) -> None:
        try:
            self.proc.stdin.close()
        except OSError:
            pass
        self.proc.wait(timeout=30)


def run(names: list, count: int, start: int, jobs: int, cpu: float, shared: bool,
        time_limit: float) -> dict:
    """{reader: [result dicts]} for inputs start..start+count-1 of each reader."""
    import selectors
    # interleaved, so a time limit cuts every reader's share alike
    todo = [(n, s) for s in range(start, start + count) for n in names]
    results: dict = defaultdict(list)
    workers = [Worker(cpu, shared) for _ in range(max(1, jobs))]
    sel = selectors.DefaultSelector()
    for w in workers:
        sel.register(w.proc.stdout, selectors.EVENT_READ, w)
    t0 = time.monotonic()
    pending = iter(todo)
    busy = 0
    done = 0
    for w in workers:
        job = next(pending, None)
        if job:
            w.send(*job)
            busy += 1
    while busy:
        for key, _ in sel.select(timeout=60):
            w = key.data
            r = w.receive()
            if r is None:
                name, seed = w.job
                r = {"reader": name, "seed": seed, "kind": "hang",
                     "detail": f"worker ended (exit {w.proc.returncode}): CPU cap or crash",
                     "cpu": None, "peak": None, "size": None}
                sel.unregister(w.proc.stdout)
                workers.remove(w)
                w = Worker(cpu, shared)
                workers.append(w)
                sel.register(w.proc.stdout, selectors.EVENT_READ, w)
            results[r["reader"]].append(r)
            done += 1
            busy -= 1
            if done % 500 == 0:
                print(f"# {done}/{len(todo)} inputs, {time.monotonic() - t0:.0f} s", flush=True)
            job = None if time.monotonic() - t0 > time_limit else next(pending, None)
            if job:
                w.send(*job)
                busy += 1
    for w in workers:
        w.close()
    return results


def group_of(r: dict) -> str:
    if r["kind"] == "other":
        return r["detail"].split(": ", 1)[0]          # "TypeError at file.py:12 fn"
    return r["kind"]


def keep_failures(results: dict, keep: Path, shared: bool) -> list:
    """Minimise one input per failure group and write it under ``keep``/<reader>/."""
    from fuzz import harness as h
    kept = []
    folder = Path(tempfile.mkdtemp(prefix="mpeg4fba-fuzz-min-"))
    for name, rs in results.items():
        reader = h.READERS[name]
        first = {}
        for r in rs:
            if r["kind"] in ("other", "hang", "memory"):
                first.setdefault(group_of(r), r)
        for group, r in first.items():
            data = h.locate(name, r["seed"], shared)
            if r["kind"] == "other":
                def same(outcome, group=group):
                    return outcome[0] == "other" and outcome[1].startswith(group)
                data = h.minimise(reader, data, folder, same)
            digest = hashlib.sha256(data).hexdigest()[:12]
            label = group.split(" ")[0].lower()
            out = keep / name / f"{label}-{digest}{reader.suffix}"
            out.parent.mkdir(parents=True, exist_ok=True)
            out.write_bytes(data)
            kept.append((name, group, r["seed"], len(data), out))
    return kept


def table(results: dict) -> str:
    head = ["reader", "inputs", "own errors", "accepted", "other exceptions", "hangs",
            "memory blow-ups", "worst CPU (s)", "worst peak RSS (MB / input kB)"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, rs in results.items():
        c = Counter(r["kind"] for r in rs)
        cpus = [r["cpu"] for r in rs if r["cpu"] is not None]
        peaks = [(r["peak"], r["size"]) for r in rs if r["peak"] is not None]
        worst = max(peaks, default=(0, 0))
        lines.append("| " + " | ".join([
            name, str(len(rs)), str(c["error"]), str(c["accepted"]), str(c["other"]),
            str(c["hang"]), str(c["memory"]), f"{max(cpus, default=0):.2f}",
            f"{worst[0] / MB:.0f} / {worst[1] / 1000:.0f}"]) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--count", type=int, default=1000, help="inputs per reader (default 1000)")
    ap.add_argument("--start", type=int, default=0, help="number of the first input")
    ap.add_argument("--time-limit", type=float, default=3600.0,
                    help="stop starting inputs after this many seconds (default 3600)")
    ap.add_argument("--readers", default="", help="comma-separated (default: all)")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--cpu", type=float, default=1.0, help="CPU seconds per input (default 1)")
    ap.add_argument("--no-shared", action="store_true", help="seeds of our own only")
    ap.add_argument("--keep", type=Path, default=REPO / "tests" / "fuzz" / "regressions",
                    help="where minimised failures go")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        worker(args.cpu, not args.no_shared)
        return 0
    from fuzz import harness as h
    names = [n for n in args.readers.split(",") if n] or list(h.READERS)
    unknown = [n for n in names if n not in h.READERS]
    if unknown:
        ap.error(f"unknown reader(s) {', '.join(unknown)}; known: {', '.join(h.READERS)}")
    t0 = time.monotonic()
    print(f"# fuzzing {', '.join(names)}: inputs {args.start}..{args.start + args.count - 1} "
          f"each, {args.jobs} workers, {args.cpu:g} s CPU per input, seeds "
          f"{json.dumps({n: len(h.seeds(h.READERS[n], not args.no_shared)) for n in names})}",
          flush=True)
    results = run(names, args.count, args.start, args.jobs, args.cpu, not args.no_shared,
                  args.time_limit)
    print(f"\n# {sum(map(len, results.values()))} inputs in {time.monotonic() - t0:.0f} s\n")
    print(table(results))
    groups = Counter((n, group_of(r)) for n, rs in results.items() for r in rs
                     if r["kind"] in ("other", "hang", "memory"))
    if groups:
        print("\n# failures by reader and kind (type and raising frame for exceptions):")
        for (n, g), c in groups.most_common():
            print(f"  {n}: {c} x {g}")
        for name, group, seed, size, out in keep_failures(results, args.keep, not args.no_shared):
            print(f"  kept {name} input {seed} ({group}), minimised to {size} bytes: {out}")
    return 1 if groups else 0


if __name__ == "__main__":
    sys.exit(main())
