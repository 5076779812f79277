#!/usr/bin/env python3
"""The reference external grasp detector: a small but real one, speaking the process protocol
(version 1, docs/external-components.md) on stdin and stdout. Copy it and put AnyGrasp,
Contact-GraspNet or your own network where `detect` is.

It needs only Debian's python3 and python3-numpy. Per request it reads the depth image (.npy),
lifts it into the bin's frame through the intrinsics and extrinsics it is given, makes a height map
of the bin (4 mm cells, the highest point of each), and proposes a top-down grasp at each local
maximum of it: the hand turned to close across the narrowest width of the top there (12 directions),
its pads reaching below the top by up to 2.5 cm, where the cells just outside both pads are low
enough for the fingers to go down, the pads opening 12 mm (or the request's finger margin, if more)
wider than the top each side. Best first: the highest tops first, then the narrowest.

Run by the harness (experiments/external_detector.yaml):  python3 tools/external_grasps.py [--frame camera|world]
For the failure tests: --misbehave crash|hang|garbage|error|wrong-frame --every K does that on
every K-th request (by id) instead of answering. For the protocol's overhead (minimanip_microbench):
--load-only reads the images and answers no grasp.
"""
import argparse
import json
import os
import resource
import sys
import time

import numpy as np

CELL = 0.004        # [m] the height map's cells
MIN_HEIGHT = 0.012  # [m] a top at least this far above the bin's floor
MAX_BITE = 0.025    # [m] the pads reach at most this far below the top
DROP = 0.012        # [m] an object's edge: where the height falls this far below its top
MIN_MARGIN = 0.012  # [m] the pads open at least this much wider than the top each side (it is narrower than below)
FLOOR_GAP = 0.004   # [m] the fingertips stay this far above the floor


def lift(depth, cam, T_world_region):
    """The depth image's points in the region's frame (N x 3)."""
    h, w = depth.shape
    v, u = np.nonzero(depth > 0)
    z = depth[v, u].astype(np.float64)
    x = (u - cam["cx"]) * z / cam["fx"]
    y = (v - cam["cy"]) * z / cam["fy"]
    p_cam = np.stack([x, y, z, np.ones_like(z)])
    T_region_camera = np.linalg.inv(T_world_region) @ np.asarray(cam["T_world_camera"], dtype=np.float64)
    return (T_region_camera @ p_cam)[:3].T


def height_map(points, half):
    """The highest point per cell of the region's footprint (-inf where nothing is seen)."""
    nx, ny = int(np.ceil(2 * half[0] / CELL)), int(np.ceil(2 * half[1] / CELL))
    inside = (np.abs(points[:, 0]) < half[0]) & (np.abs(points[:, 1]) < half[1]) & (points[:, 2] < half[2]) & (points[:, 2] > -0.01)
    p = points[inside]
    ix = np.clip(((p[:, 0] + half[0]) / CELL).astype(int), 0, nx - 1)
    iy = np.clip(((p[:, 1] + half[1]) / CELL).astype(int), 0, ny - 1)
    hm = np.full((nx, ny), -np.inf)
    np.maximum.at(hm, (ix, iy), p[:, 2])
    seen = np.isfinite(hm)
    hm[~seen] = 0.0  # unseen cells count as the floor (shadows beside tall objects)
    return hm


def local_maxima(hm, radius):
    """Cells that are the highest within `radius` cells and above MIN_HEIGHT."""
    best = hm.copy()
    padded = np.pad(hm, radius, constant_values=-np.inf)
    for dx in range(-radius, radius + 1):
        for dy in range(-radius, radius + 1):
            shifted = padded[radius + dx:radius + dx + hm.shape[0], radius + dy:radius + dy + hm.shape[1]]
            best = np.maximum(best, shifted)
    peaks = np.argwhere((hm >= best) & (hm > MIN_HEIGHT))
    return peaks


def sample(hm, x, y, half):
    """The height map at region coordinates (x, y); the floor outside it."""
    i = int((x + half[0]) / CELL)
    j = int((y + half[1]) / CELL)
    if i < 0 or j < 0 or i >= hm.shape[0] or j >= hm.shape[1]:
        return 0.0
    return hm[i, j]


def detect(depth, request):
    cam = request["camera"]
    region = request["region"]
    grip = request["gripper"]
    T_world_region = np.asarray(region["T_world_region"], dtype=np.float64)
    half = region["half_extents"]
    hm = height_map(lift(depth, cam, T_world_region), half)
    stroke = grip["stroke"]
    finger = grip["finger_thickness"]
    # The pads open this much wider than the top's width each side: the request's finger margin, or
    # more (a top is narrower than the object below it).
    margin = max(grip["finger_margin"], MIN_MARGIN)
    grasps = []
    peaks = sorted(local_maxima(hm, radius=int(0.02 / CELL)).tolist(), key=lambda ij: -hm[ij[0], ij[1]])
    taken = []  # a flat top is many equal maxima: one grasp per 2 cm
    r = int(0.025 / CELL)
    for i, j in peaks:
        top = hm[i, j]
        # The middle of the top's plateau about the maximum (cells within 3 mm of its height).
        lo_i, lo_j = max(0, i - r), max(0, j - r)
        window = hm[lo_i:i + r + 1, lo_j:j + r + 1]
        ii, jj = np.nonzero(window >= top - 0.003)
        cx = -half[0] + (lo_i + ii.mean() + 0.5) * CELL
        cy = -half[1] + (lo_j + jj.mean() + 0.5) * CELL
        if any((cx - x) ** 2 + (cy - y) ** 2 < 0.02 ** 2 for x, y in taken):
            continue
        taken.append((cx, cy))
        bite = min(MAX_BITE, top - FLOOR_GAP)
        if bite < 0.006:
            continue
        tip = top - bite  # the fingertips' height
        best = None
        for angle in np.arange(12) * np.pi / 12:
            d = np.array([np.cos(angle), np.sin(angle)])
            edges = []
            for side in (-1, 1):  # walk out from the top to where the height drops
                s = 0.0
                while s < stroke and sample(hm, cx + side * s * d[0], cy + side * s * d[1], half) > top - DROP:
                    s += CELL / 2
                edges.append(s)
            width = edges[0] + edges[1]
            opening = width + 2 * margin
            if opening > stroke:
                continue
            # The fingers go down outside the pads: the cells there must be below the fingertips.
            clear = True
            for side, e in ((-1, edges[0]), (1, edges[1])):
                for s in np.arange(e + margin - finger / 2, e + margin + finger, CELL / 2):
                    if sample(hm, cx + side * s * d[0], cy + side * s * d[1], half) > tip:
                        clear = False
                if not clear:
                    break
            if not clear:
                continue
            centre = (edges[1] - edges[0]) / 2  # the middle between the edges, along d
            if best is None or width < best[0]:
                best = (width, angle, centre, opening)
        if best is None:
            continue
        width, angle, centre, opening = best
        d = np.array([np.cos(angle), np.sin(angle), 0.0])
        # The TCP: z down into the bin, y the closing direction, x = y x z; its tips bite below the top.
        z_axis = np.array([0.0, 0.0, -1.0])
        y_axis = d
        x_axis = np.cross(y_axis, z_axis)
        T_region_tcp = np.eye(4)
        T_region_tcp[:3, 0], T_region_tcp[:3, 1], T_region_tcp[:3, 2] = x_axis, y_axis, z_axis
        # The pads' tips are pad_z_max along z from the TCP: the TCP that far above the tips.
        tcp_height = top - bite + grip["pad_z_max"]
        T_region_tcp[:3, 3] = [cx + centre * d[0], cy + centre * d[1], tcp_height]
        grasps.append((top, width, T_world_region @ T_region_tcp, opening))
    grasps.sort(key=lambda g: (-g[0], g[1]))  # the highest tops first, then the narrowest
    return [{"T": T, "opening": opening, "score": float(top - 0.5 * width)} for top, width, T, opening in grasps]


def answer(request, frame):
    depth = np.load(request["images"]["depth"])
    grasps = detect(depth, request)
    if frame == "camera":
        T_camera_world = np.linalg.inv(np.asarray(request["camera"]["T_world_camera"], dtype=np.float64))
        for g in grasps:
            g["T"] = T_camera_world @ g["T"]
    for g in grasps:
        g["T"] = g["T"].tolist()
        g["opening"] = float(g["opening"])
    return {"protocol": 1, "id": request["id"], "frame": frame, "grasps": grasps}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frame", choices=["camera", "world"], default="camera")
    parser.add_argument("--misbehave", choices=["crash", "hang", "garbage", "error", "wrong-frame"])
    parser.add_argument("--every", type=int, default=1)
    parser.add_argument("--load-only", action="store_true")
    args = parser.parse_args()
    if args.every < 1:
        parser.error("--every takes a positive number")
    for line in sys.stdin:
        request = json.loads(line)
        started = time.time()
        if args.misbehave and request["id"] % args.every == 0:
            if args.misbehave == "crash":
                sys.stderr.write("external_grasps: crashing on request %d as asked\n" % request["id"])
                sys.stderr.flush()
                # No core file: where cores are enabled, dumping one delays the end the harness waits for.
                resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
                os.abort()
            if args.misbehave == "hang":
                time.sleep(3600)
            if args.misbehave == "garbage":
                sys.stdout.write("Loading weights... 100%% [request %d]\n" % request["id"])
                sys.stdout.flush()
                continue
            if args.misbehave == "error":
                print(json.dumps({"protocol": 1, "id": request["id"], "error": "no grasp (asked to fail)"}), flush=True)
                continue
        if args.load_only:
            for kind in ("depth", "rgb"):
                if request["images"][kind]:
                    np.load(request["images"][kind])
            print(json.dumps({"protocol": 1, "id": request["id"], "frame": args.frame, "grasps": []}), flush=True)
            continue
        try:
            reply = answer(request, args.frame)
            if args.misbehave == "wrong-frame" and request["id"] % args.every == 0:
                reply["frame"] = "world" if args.frame == "camera" else "camera"
        except Exception as e:  # the protocol's own failure: said, not crashed on
            reply = {"protocol": 1, "id": request.get("id"), "error": "%s: %s" % (type(e).__name__, e)}
        print(json.dumps(reply), flush=True)
        sys.stderr.write("external_grasps: request %d: %d grasps in %.0f ms\n"
                         % (request["id"], len(reply.get("grasps", [])), 1e3 * (time.time() - started)))
        sys.stderr.flush()


if __name__ == "__main__":
    main()
