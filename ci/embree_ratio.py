#!/usr/bin/env python3
"""Embree (embreex) against shellsim's float tracer on the same triangles and rays.

Usage: embree_ratio.py BIN ROUNDS SCENE... — BIN is `examples/tracer_speed`. Per scene and
round: BIN times shellsim's one-ray path (`trace_counted`), its packet path
(`trace_packet`) and the bare grid walk on one thread and writes the scene's triangles (a
fan per patch) and the rays; then Embree traces the same rays: `EmbreeScene.run`, which
is a C loop of rtcIntersect1 (one ray at a time, one thread, float32). Each figure is the
best over the rounds (each round itself a best of 5). Prints a Markdown table, and checks
that Embree's nearest patch agrees with shellsim's on most rays.

Origins move 1e-6·scale along the ray for Embree: `run` fixes tnear at 0 and the rays
start on their source patch, which shellsim leaves out.
"""
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from embreex import rtcore_scene
from embreex.mesh_construction import TriangleMesh

REPS = 5


def embree(d, scale):
    """Best time of REPS batch calls, the per-call time of one-ray calls, agreement."""
    tris = np.fromfile(f"{d}/tris.f64", dtype="<f8").reshape(-1, 3, 3)
    tri_patch = np.fromfile(f"{d}/tri_patch.u32", dtype="<u4").astype(np.int64)
    rays = np.fromfile(f"{d}/rays.f64", dtype="<f8").reshape(-1, 6)
    ours = np.fromfile(f"{d}/hits.i64", dtype="<i8")
    o, dirs = rays[:, :3], rays[:, 3:]
    unit = dirs / np.linalg.norm(dirs, axis=1)[:, None]
    origins = np.ascontiguousarray((o + 1e-6 * scale * unit).astype(np.float32))
    dirs32 = np.ascontiguousarray(dirs.astype(np.float32))
    scene = rtcore_scene.EmbreeScene()
    TriangleMesh(scene, tris.astype(np.float32))
    scene.run(origins[:1], dirs32[:1])  # commits: the BVH is built outside the timing
    best = float("inf")
    for _ in range(REPS):
        s = time.perf_counter()
        prim = scene.run(origins, dirs32)
        best = min(best, time.perf_counter() - s)
    theirs = np.where(prim >= 0, tri_patch[np.maximum(prim, 0)], -1)
    k = min(2000, len(origins))
    s = time.perf_counter()
    for i in range(k):
        scene.run(origins[i : i + 1], dirs32[i : i + 1])
    per_call = (time.perf_counter() - s) / k
    return best, per_call, float(np.mean(theirs == ours)), len(tris)


def main():
    binary, rounds, scenes = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    rows = []
    for sc in scenes:
        best = {}
        with tempfile.TemporaryDirectory() as d:
            for _ in range(rounds):
                out = subprocess.run(
                    [binary, sc, "--reps", str(REPS), "--dump", d],
                    env=env, check=True, capture_output=True, text=True,
                ).stdout
                ours = json.loads(out.strip().splitlines()[-1])
                e, per_call, agree, ntri = embree(d, ours["scale"])
                for k, v in [("one", ours["one_s"]), ("packet", ours["packet_s"]),
                             ("dda", ours["dda_only_s"]), ("embree", e), ("call", per_call)]:
                    best[k] = min(best.get(k, float("inf")), v)
        n = ours["rays"]
        rows.append((ours, ntri, agree, best, n))
    print("| scene | patches (triangles) | rays | shellsim one-ray | shellsim packet | "
          "bare walk | Embree rtcIntersect1 | packet / Embree | one-ray / Embree | "
          "ids agree | cells, nonempty, tests per ray |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for ours, ntri, agree, b, n in rows:
        m = lambda t: f"{n / t / 1e6:.2f} M/s"
        print(f"| {ours['scene']} | {ours['patches']} ({ntri}) | {n} | {m(b['one'])} | "
              f"{m(b['packet'])} | {m(b['dda'])} | {m(b['embree'])} | "
              f"{b['embree'] / b['packet']:.2f}× | {b['embree'] / b['one']:.2f}× | "
              f"{agree:.5f} | {ours['cells_per_ray']}, {ours['nonempty_per_ray']}, "
              f"{ours['tests_per_ray']} |")
    calls = ", ".join(f"{r[3]['call'] * 1e6:.2f}" for r in rows)
    print(f"\nEmbree one ray per `run` call from Python: {calls} µs per call "
          "(the binding's overhead; not compared).")
    print("bare walk: the grid walk alone, setup and the same cells, no patch tests.")
    bad = [r[0]["scene"] for r in rows if r[2] < 0.99]
    if bad:
        sys.exit(f"embree-ratio: Embree's ids agree with ours on under 99% of rays: {bad}")


if __name__ == "__main__":
    main()
