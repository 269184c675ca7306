#!/usr/bin/env python3
"""Issue 31's scale table as Markdown, from ci/scale-table.sh's CSV: per scene size and
command, CPU seconds (scaled to every row where a block of rows ran), peak RSS and patch
tests per ray on the paper's grid and on the grid sized to the scene, then the growth
exponents of the whole matrix (CPU ∝ N^k) between sizes.

    python3 ci/scale-table.py docs/scale/scale.csv > docs/scale/scale.md
"""
import csv, math, sys

rows = list(csv.DictReader(open(sys.argv[1])))
key = lambda r: (int(r["patches"]), r["command"], r["grid"])
by = {key(r): r for r in rows}
sizes = sorted({int(r["patches"]) for r in rows})
commands = []
for r in rows:
    if r["command"] not in commands:
        commands.append(r["command"])

def cpu(n, c, g):
    """CPU seconds of the whole job: a block of rows scaled to all n rows."""
    r = by.get((n, c, g))
    if r is None:
        return None
    s = float(r["cpu_s"])
    rows_run = int(r["rows"])
    return s * n / rows_run if c != "reference" and rows_run < n else s

print("# Scale: the Cornell room subdivided, on the paper's grid and on the grid sized to the scene\n")
print("Made by `bash ci/scale-table.sh > docs/scale/scale.csv && python3 ci/scale-table.py docs/scale/scale.csv > docs/scale/scale.md`"
      " (2 cores; CPU = user + system seconds). `paper`: `--cell 0.05`, the extent / 20, the only grid before issue 31;"
      " `sized`: the default now, the extent / max(20, ⌈1.6·∛N⌉). `reference`: 10⁶ random rays from patch 0."
      " Matrices: 969 ring rays per source, every row — except where `rows` is smaller: that block of rows"
      " (the first ones) ran and its CPU time is scaled to all rows (marked *). `radiosity`: the float matrix, the solve and the picture.\n")
print("| patches | command | rows run | CPU s, paper | CPU s, sized | ratio | peak RSS MB, sized | patch tests / ray, paper → sized | cells / ray, paper → sized |")
print("| ---: | --- | ---: | ---: | ---: | ---: | ---: | --- | --- |")
for n in sizes:
    for c in commands:
        p, s = by.get((n, c, "paper")), by.get((n, c, "sized"))
        if p is None or s is None:
            continue
        cp, cs = cpu(n, c, "paper"), cpu(n, c, "sized")
        star = "*" if c != "reference" and int(s["rows"]) < n else ""
        tests = f"{p['tests_per_ray']} → {s['tests_per_ray']}" if s["tests_per_ray"] else ""
        cells = f"{p['cells_per_ray']} → {s['cells_per_ray']}" if s["cells_per_ray"] else ""
        print(f"| {n:,} | {c} | {s['rows']} | {cp:.2f}{star} | {cs:.2f}{star} | {cp / cs:.2f}× | {int(s['peak_rss_kb']) / 1024:.0f} | {tests} | {cells} |")
print("\n## Growth exponents (whole-job CPU ∝ N^k)\n")
print("| command | grid | 1k → 20k | 1k → 100k |")
print("| --- | --- | ---: | ---: |")
for c in commands:
    if c == "reference":
        continue
    for g in ("paper", "sized"):
        ks = []
        for hi in (19663, 100800):
            a, b = cpu(1008, c, g), cpu(hi, c, g)
            ks.append(f"{math.log(b / a) / math.log(hi / 1008):.2f}" if a and b else "—")
        print(f"| {c} | {g} | {ks[0]} | {ks[1]} |")
