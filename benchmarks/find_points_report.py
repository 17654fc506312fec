"""The tables of ``benchmarks/bench_find_points.py``: found points against the landmark
points by group, slice and point, their plausibility, the time, and cloning with found
points and with noisy ones against with landmark points; with the goals they are read
against (:data:`GOALS`)."""
from __future__ import annotations

import os

import numpy as np

from benchmarks import ict
from mpeg4fba.fba.featurepoints import point_order

#: Point groups of the landmark truth.
GROUPS = {
    "2 inner lips": ("2.2", "2.3", "2.4", "2.5", "2.6", "2.7", "2.8", "2.9"),
    "2 chin (contour)": ict.LANDMARK_CONTOUR,
    "3 eyes": ("3.1", "3.2", "3.3", "3.4", "3.7", "3.8", "3.11", "3.12"),
    "4 brows": ("4.1", "4.2", "4.3", "4.4", "4.5", "4.6"),
    "8 outer lips": ("8.1", "8.2", "8.3", "8.4", "8.5", "8.6", "8.7", "8.8", "8.9", "8.10"),
    "9 nose": ("9.3", "9.4", "9.5", "9.15"),
}
#: Noise levels (sigma per axis, mm).
NOISE_MM = (0.5, 1.0, 2.0)
#: Goals of issue 18 (% ES0 for the points; ratios for cloning).
GOALS = {"median": 1.5, "p95": 4.0, "max": 8.0, "clone_ratio": 1.25, "noise_1mm_max_ratio": 1.5}
#: Plausibility: how far off a surface (% ES0) a point may lie.
ON_SURFACE = 2.0
#: The landmark-defined ids, in the standard's order.
LANDMARK_IDS = tuple(point_order(ict.LANDMARK_POINTS))


def stats(x) -> tuple:
    x = np.asarray(list(x), dtype=np.float64)
    if not len(x):
        return (float("nan"),) * 3
    return float(np.median(x)), float(np.percentile(x, 95)), float(np.max(x))


def fmt(x: float, nd: int = 2) -> str:
    return "-" if x is None or not np.isfinite(x) else f"{x:.{nd}f}"


def point_rows(cases: list, keep=lambda c: True) -> dict:
    """group -> list of errors over the cases kept."""
    out = {g: [] for g in GROUPS}
    for c in cases:
        if "errors" not in c or not keep(c):
            continue
        for g, ids in GROUPS.items():
            out[g].extend(c["errors"][k] for k in ids if k in c["errors"])
    return out


def worst_of(cases: list, ids) -> tuple:
    best = (-1.0, None, None)
    for i, c in enumerate(cases):
        for k in ids:
            e = c.get("errors", {}).get(k)
            if e is not None and e > best[0]:
                best = (e, k, i)
    return best


def case_name(c: dict) -> str:
    return (f"id{c['identity']} ({c['seed']}) {c['mesh']}, {'eyes' if c['eyes'] else 'no eyes'}, "
            f"{c['placement']}")


def report_points(cases: list) -> dict:
    summary = {}
    print("\n### Found points against the landmark points (% of ES0, head frame)\n")
    print("| group | points | median | p95 | max | worst (point, head) |")
    print("|---|---:|---:|---:|---:|---|")
    rows = point_rows(cases)
    crisp = [e for g, v in rows.items() if g != "2 chin (contour)" for e in v]
    allv = [e for v in rows.values() for e in v]
    for g, v in list(rows.items()) + [("all but the contour", crisp), ("**all**", allv)]:
        ids = GROUPS.get(g, LANDMARK_IDS if g == "**all**" else
                         tuple(k for k in LANDMARK_IDS if k not in ict.LANDMARK_CONTOUR))
        m, p, x = stats(v)
        e, k, i = worst_of(cases, ids)
        where = f"{k}, {case_name(cases[i])}" if k else "-"
        print(f"| {g} | {len(v)} | {fmt(m)} | {fmt(p)} | {fmt(x)} | {where} |")
        summary[g.strip('*')] = {"n": len(v), "median": m, "p95": p, "max": x}
    m, p, x = stats(allv)
    print(f"\nGoals: median <= {GOALS['median']} ({'met' if m <= GOALS['median'] else 'NOT met'}), "
          f"p95 <= {GOALS['p95']} ({'met' if p <= GOALS['p95'] else 'NOT met'}), "
          f"max <= {GOALS['max']} ({'met' if x <= GOALS['max'] else 'NOT met'}).")

    print("\n### By slice (all landmark points; % of ES0)\n")
    print("| slice | heads | median | p95 | max | worst group (its max) |")
    print("|---|---:|---:|---:|---:|---|")
    slices = [("full", lambda c: c["mesh"] == "full"),
              ("decimated", lambda c: c["mesh"] == "decimated"),
              ("with eyeballs", lambda c: c["eyes"]), ("without eyeballs", lambda c: not c["eyes"])]
    slices += [(f"up {u}", (lambda u: lambda c: c["up"] == u)(u)) for u in ict.UP_AXES]
    slices += [(f"scale {s:g}", (lambda s: lambda c: c["scale"] == s)(s)) for s in ict.SCALES]
    slices += [("tilt < 10 deg", lambda c: c["tilt"] < 10), ("tilt >= 10 deg", lambda c: c["tilt"] >= 10)]
    summary["slices"] = {}
    for name, keep in slices:
        r = point_rows(cases, keep)
        v = [e for x in r.values() for e in x]
        n = sum(1 for c in cases if keep(c) and "errors" in c)
        m, p, x = stats(v)
        wg = max(r, key=lambda g: max(r[g]) if r[g] else -1)
        print(f"| {name} | {n} | {fmt(m)} | {fmt(p)} | {fmt(x)} | {wg} ({fmt(max(r[wg]) if r[wg] else None)}) |")
        summary["slices"][name] = {"heads": n, "median": m, "p95": p, "max": x}

    print("\n### Per group and slice: median / max (% of ES0)\n")
    print("| slice | " + " | ".join(GROUPS) + " |")
    print("|---|" + "---:|" * len(GROUPS))
    for name, keep in slices:
        r = point_rows(cases, keep)
        cells = [f"{fmt(stats(r[g])[0])} / {fmt(stats(r[g])[2])}" for g in GROUPS]
        print(f"| {name} | " + " | ".join(cells) + " |")
        summary["slices"][name]["groups"] = {g: stats(r[g]) for g in GROUPS}

    print("\n### Per point (% of ES0)\n")
    print("| point | rule | median | p95 | max | missing |")
    print("|---|---|---:|---:|---:|---:|")
    summary["points"] = {}
    for fp in LANDMARK_IDS:
        v = [c["errors"][fp] for c in cases if fp in c.get("errors", {})]
        miss = sum(1 for c in cases if fp in c.get("landmark_missing", []))
        rule, marks, _ = ict.LANDMARK_POINTS[fp]
        m, p, x = stats(v)
        print(f"| {fp} | {rule} {'-'.join(map(str, marks))} | {fmt(m)} | {fmt(p)} | {fmt(x)} | {miss} |")
        summary["points"][fp] = {"median": m, "p95": p, "max": x, "missing": miss}
    return summary


def report_plausibility(cases: list) -> dict:
    print("\n### Points the landmarks do not define: plausibility\n")
    ok = [c for c in cases if "plausibility" in c]
    counts = {"checked": 0, "off_surface": [], "outside_box": [], "wrong_side": []}
    vs_picked, sym_found, sym_picked = [], [], []
    for c in ok:
        for k, row in c["plausibility"]["points"].items():
            counts["checked"] += 1
            tag = f"{k} ({case_name(c)})"
            if not row["on_surface"]:
                counts["off_surface"].append(f"{k} {row['surface']:.1f} % ({case_name(c)})")
            if not row["in_box"]:
                counts["outside_box"].append(tag)
            if row.get("side_ok") is False:
                counts["wrong_side"].append(f"{k} x = {row['x']:+.1f} % ({case_name(c)})")
            if "vs_picked" in row:
                vs_picked.append(row["vs_picked"])
        for pair, (f, p) in c["plausibility"]["symmetry"].items():
            sym_found.append(f)
            sym_picked.append(p)
    print(f"{counts['checked']} found points checked on {len(ok)} heads: "
          f"{len(counts['off_surface'])} off a surface (> {ON_SURFACE} % ES0), "
          f"{len(counts['outside_box'])} outside the head's box, "
          f"{len(counts['wrong_side'])} on the wrong side of the mid plane.\n")
    for what in ("off_surface", "outside_box", "wrong_side"):
        for line in counts[what][:8]:
            print(f"- {what}: {line}")
        if len(counts[what]) > 8:
            print(f"- {what}: ... and {len(counts[what]) - 8} more")
    per = {}
    for c in ok:
        for k, row in c["plausibility"]["points"].items():
            if "vs_picked" in row:
                per.setdefault(k, []).append(row["vs_picked"])
    far = sorted(per, key=lambda k: -np.median(per[k]))[:12]
    if far:
        print("\nFurthest from our picked points (median / max % ES0; a reference, not truth): "
              + ", ".join(f"{k} {np.median(per[k]):.1f} / {max(per[k]):.1f}" for k in far))
    print("\n| measure (% ES0) | median | p95 | max |\n|---|---:|---:|---:|")
    for name, v in (("distance to our picked point (reference, not truth)", vs_picked),
                    ("mirror asymmetry of found pairs", sym_found),
                    ("mirror asymmetry of our picked pairs (the heads' own)", sym_picked)):
        m, p, x = stats(v)
        print(f"| {name} | {fmt(m)} | {fmt(p)} | {fmt(x)} |")
    return {"checked": counts["checked"], "off_surface": counts["off_surface"],
            "outside_box": counts["outside_box"], "wrong_side": counts["wrong_side"],
            "vs_picked": stats(vs_picked), "symmetry_found": stats(sym_found),
            "symmetry_picked": stats(sym_picked),
            "vs_picked_per_point": {k: stats(v) for k, v in per.items()}}


def report_raised(cases: list) -> dict:
    raised = [c for c in cases if "raised" in c]
    print(f"\n### Heads on which detection raised: {len(raised)} of {len(cases)}\n")
    for c in raised:
        print(f"- {case_name(c)}: {c['raised']}")
    missing = {}
    for c in cases:
        for k in c.get("missing", []):
            missing[k] = missing.get(k, 0) + 1
    if missing:
        print("\nPoints reported missing (count of heads): "
              + ", ".join(f"{k} {v}" for k, v in sorted(missing.items())))
    low = [c["lowest_confidence"] for c in cases if "lowest_confidence" in c]
    if low:
        print("Lowest confidence per head: median {:.2f}, worst {:.2f} ({})".format(
            float(np.median([v for _, v in low])), *min(((v, k) for k, v in low))))
    return {"raised": [(case_name(c), c["raised"]) for c in raised], "missing": missing}


def report_time(cases: list) -> dict:
    full = [c for c in cases if c["mesh"] == "full" and "time" in c]
    dec = [c for c in cases if c["mesh"] == "decimated" and "time" in c]
    print("\n### Time of find_feature_points (s)\n")
    print("| heads | vertices (median) | wall median | wall worst | CPU median | CPU worst |")
    print("|---|---:|---:|---:|---:|---:|")
    out = {}
    for name, cs in (("full", full), ("decimated", dec)):
        if not cs:
            continue
        t = [c["time"] for c in cs]
        u = [c["cpu"] for c in cs if "cpu" in c]
        nv = int(np.median([c["vertices"] for c in cs]))
        print(f"| {name} ({len(cs)}) | {nv:,} | {np.median(t):.2f} | {max(t):.2f} | "
              f"{np.median(u):.2f} | {max(u):.2f} |")
        out[name] = {"median": float(np.median(t)), "worst": float(max(t)), "vertices": nv,
                     "cpu_median": float(np.median(u)), "cpu_worst": float(max(u))}
    print("\nGoal: <= 3 s on a 30,000-vertex head.  Timed after one untimed warm-up call (the "
          "first call of a process also builds the detector's template); CPU is the process's "
          "CPU time (all its threads); the machine is shared, so wall time includes waiting "
          f"(load average {os.getloadavg()[0]:.1f} at the end of the run).")
    return out


def report_cloning(pairs: list, source_seed: int) -> dict:
    print(f"\n### Cloning with found points against with landmark points "
          f"(source ICT-{source_seed}, eight expressions, scaling off; % of ES0)\n")
    print("auto: the target's points found, and the source's skin points found the same way "
          "(as `mpeg4fba clone` does when it finds all the target's points); landmark: the "
          "target's landmark points, the source's own points.\n")
    print("| target | auto mean | auto max | landmark mean | landmark max | ratio mean | ratio max "
          "| picked mean / max | landmark + found rest mean / max |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    rm, rx, hm, hx = [], [], [], []
    pairs = sorted(pairs, key=lambda p: not p.get("eyes", True))
    for p in pairs:
        a, l = p["auto"], p["landmark"]
        if "raised" in a or "raised" in l:
            why = a.get("raised") or l.get("raised")
            short = why if len(why) <= 160 else why[:60] + " ... " + why[-95:]
            print(f"| {p['name']} | raised: {short} | | | | | | | |")
            continue
        m, x = a["mean"] / l["mean"], a["max"] / l["max"]
        rm.append(m)
        rx.append(x)
        k = p.get("picked", {})
        h = p.get("landmark_found_rest", {})
        if "mean" in h:
            hm.append(a["mean"] / h["mean"])
            hx.append(a["max"] / h["max"])
        print(f"| {p['name']} | {a['mean']:.3f} | {a['max']:.2f} | {l['mean']:.3f} | {l['max']:.2f} "
              f"| {m:.2f} | {x:.2f} | {fmt(k.get('mean'), 3)} / {fmt(k.get('max'))} "
              f"| {fmt(h.get('mean'), 3)} / {fmt(h.get('max'))} |")
    sm, sx = stats(rm), stats(rx)
    print("\n(Heads with eyeballs first, then the same meshes without them.)")
    print(f"\nRatio auto / landmark over {len(rm)} pairs: mean median {fmt(sm[0])}, worst {fmt(sm[2])}; "
          f"max median {fmt(sx[0])}, worst {fmt(sx[2])} (goal <= {GOALS['clone_ratio']}).")
    raised = [p for p in pairs if "raised" in p["auto"] or "raised" in p["landmark"]]
    if raised:
        print(f"{len(raised)} of {len(pairs)} pairs raised (listed above).")
    print("(picked: the same target with our picked points, spec_fixtures/ict/feature_points.json, "
          "for context: the landmark points are the baseline of the goal.)")
    out = {"ratio_mean": sm, "ratio_max": sx, "raised": len(raised)}
    if hm:
        out["ratio_to_landmark_found_rest"] = {"mean": stats(hm), "max": stats(hx)}
        print(f"(landmark + found rest: the landmark points where the landmarks define a point, "
              f"the found ones, as `clone` puts them, elsewhere; the landmark run's rest are our "
              f"picked points, on the same vertices as the source's, which no detector has. "
              f"Ratio auto / that over {len(hm)} pairs: mean median {fmt(stats(hm)[0])}, worst "
              f"{fmt(stats(hm)[2])}; max median {fmt(stats(hx)[0])}, worst {fmt(stats(hx)[2])}: "
              f"context, not the goal's baseline.)")
    return out


def snap_options(mm: float) -> tuple:
    """The clonings of a noise level: as given and snapped; the clean points (0 mm)
    only snapped."""
    return (False, True) if mm else (True,)


def report_noise(rows: list) -> dict:
    print("\n### Given points plus noise (sigma per axis, then back onto the surface): cloning "
          "against the clean landmark points\n")
    print("| noise | snapped | clonings | mean ratio (median / worst) | max ratio (median / p95 / worst) "
          "| worst max % ES0 |")
    print("|---|---|---:|---:|---:|---:|")
    out = {}
    for mm in (0.0,) + NOISE_MM:
        for snap in snap_options(mm):
            r = [x for x in rows if x["mm"] == mm and x["snap"] == snap and "max" in x]
            bad = [x for x in rows if x["mm"] == mm and x["snap"] == snap and "raised" in x]
            rm = [x["mean"] / x["clean_mean"] for x in r]
            rx = [x["max"] / x["clean_max"] for x in r]
            sm, sx = stats(rm), stats(rx)
            worst = max((x["max"] for x in r), default=float("nan"))
            print(f"| {mm:g} mm | {'yes' if snap else 'no'} | {len(r)}{f' ({len(bad)} raised)' if bad else ''} "
                  f"| {fmt(sm[0])} / {fmt(sm[2])} | {fmt(sx[0])} / {fmt(sx[1])} / {fmt(sx[2])} | {fmt(worst)} |")
            out[f"{mm:g}mm{' snapped' if snap else ''}"] = {"n": len(r), "raised": len(bad),
                                                            "mean_ratio": sm, "max_ratio": sx,
                                                            "worst_max": worst}
    print(f"\n(0 mm: the clean landmark points snapped, what snapping alone costs.)  Goal: 1 mm of "
          f"noise raises the max by at most {GOALS['noise_1mm_max_ratio']}x.")
    return out


# -- main ----------------------------------------------------------------------------------------
