#!/usr/bin/env python3
"""Embree (embreex) on the rays and triangles `examples/tracer_speed --dump DIR` wrote.

Usage: embree_ratio.py DIR REPS SCALE — prints one JSON line: Embree's best time over REPS
calls of `EmbreeScene.run` (a loop of rtcIntersect1 in C, one ray at a time, on one thread;
float32), the per-call cost of one-ray `run` calls on a sample, and the fraction of rays
whose nearest patch agrees with shellsim's. Origins move 1e-6·SCALE along the ray first:
`run` fixes tnear at 0, and the rays start on their source patch (shellsim excludes it).
"""
import json
import sys
import time

import numpy as np
from embreex import rtcore_scene
from embreex.mesh_construction import TriangleMesh


def main():
    d, reps, scale = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
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
    scene.run(origins[:1], dirs32[:1])  # commits (builds the BVH) outside the timing
    best = float("inf")
    for _ in range(reps):
        s = time.perf_counter()
        prim = scene.run(origins, dirs32)
        best = min(best, time.perf_counter() - s)
    theirs = np.where(prim >= 0, tri_patch[np.maximum(prim, 0)], -1)
    agree = float(np.mean(theirs == ours))

    # One ray per call from Python: mostly the binding's overhead, for scale.
    k = min(2000, len(origins))
    s = time.perf_counter()
    for i in range(k):
        scene.run(origins[i : i + 1], dirs32[i : i + 1])
    per_call = (time.perf_counter() - s) / k

    print(
        json.dumps(
            {
                "embree_s": best,
                "embree_rays_per_s": len(origins) / best,
                "per_ray_call_s": per_call,
                "agree": agree,
                "triangles": len(tris),
            }
        )
    )


if __name__ == "__main__":
    main()
