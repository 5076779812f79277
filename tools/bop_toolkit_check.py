#!/usr/bin/python3
"""Reads a dataset written by `minimanip dataset` with bop_toolkit's own loaders and checks it as
its tools would use it.

Usage: tools/bop_toolkit_check.py BOP_TOOLKIT_CHECKOUT DATASET_DIR [SPLIT]

BOP_TOOLKIT_CHECKOUT is a checkout of https://github.com/thodan/bop_toolkit (commit 32c2108 is the
last whose loaders run on Debian 12's python3-imageio 2.4; later ones import imageio.v2). It needs
Debian's python3-numpy, python3-scipy, python3-png and python3-imageio. Not run in CI (PyPI is not
reachable and the toolkit is not packaged); docs/datasets.md says what was run and what it printed.

Checks, with bop_toolkit_lib.inout and bop_toolkit_lib.misc:
  - every model loads (inout.load_ply) and its diameter (misc.calc_pts_diameter2) is models_info's;
  - every model's symmetries expand (misc.get_symmetry_transformations) into rotations;
  - every scene's camera, ground truth and ground-truth info load (inout.load_scene_camera,
    load_scene_gt, load_json), and every rgb, depth and mask image (inout.load_im, load_depth);
  - every vertex of every object's model, projected with the image's cam_K and the object's
    cam_R_m2c, cam_t_m2c (misc.project_pts), falls on its mask grown by one pixel;
  - px_count_all is the mask's pixels, px_count_visib the visible mask's.
Exit 0 when all hold, 1 otherwise.
"""
import os
import sys


def main():
    if len(sys.argv) not in (3, 4):
        sys.stderr.write(__doc__)
        return 2
    toolkit, root = sys.argv[1], sys.argv[2]
    split = sys.argv[3] if len(sys.argv) == 4 else "train"
    sys.path.insert(0, toolkit)
    import numpy as np
    from bop_toolkit_lib import inout, misc

    bad = []
    info = inout.load_json(os.path.join(root, "models", "models_info.json"), keys_to_int=True)
    models = {}
    for obj_id, m in sorted(info.items()):
        model = inout.load_ply(os.path.join(root, "models", "obj_%06d.ply" % obj_id))
        models[obj_id] = model
        d = misc.calc_pts_diameter2(model["pts"])
        if abs(d - m["diameter"]) > 1e-3:
            bad.append("obj %d: diameter %.6f in models_info, %.6f from its model" % (obj_id, m["diameter"], d))
        for s in misc.get_symmetry_transformations(m, 0.01):
            R = s["R"]
            if not np.allclose(R.dot(R.T), np.eye(3), atol=1e-6):
                bad.append("obj %d: a symmetry is not a rotation" % obj_id)
    camera = inout.load_cam_params(os.path.join(root, "camera.json"))

    scenes = images = objects = vertices = outside = 0
    for scene in sorted(os.listdir(os.path.join(root, split))):
        folder = os.path.join(root, split, scene)
        cams = inout.load_scene_camera(os.path.join(folder, "scene_camera.json"))
        gts = inout.load_scene_gt(os.path.join(folder, "scene_gt.json"))
        infos = inout.load_json(os.path.join(folder, "scene_gt_info.json"), keys_to_int=True)
        scenes += 1
        for im_id, cam in sorted(cams.items()):
            images += 1
            rgb = inout.load_im(os.path.join(folder, "rgb", "%06d.png" % im_id))
            depth = inout.load_depth(os.path.join(folder, "depth", "%06d.png" % im_id)) * cam["depth_scale"]  # [mm]
            if rgb.shape[:2] != (camera["im_size"][1], camera["im_size"][0]) or depth.shape != rgb.shape[:2]:
                bad.append("scene %s image %d: size %s, depth %s" % (scene, im_id, rgb.shape, depth.shape))
            K = cam["cam_K"]
            for gt_id, gt in enumerate(gts[im_id]):
                objects += 1
                name = "%06d_%06d.png" % (im_id, gt_id)
                mask = inout.load_im(os.path.join(folder, "mask", name)) > 0
                visib = inout.load_im(os.path.join(folder, "mask_visib", name)) > 0
                gi = infos[im_id][gt_id]
                if int(mask.sum()) != gi["px_count_all"] or int(visib.sum()) != gi["px_count_visib"]:
                    bad.append("scene %s %s: pixel counts differ from scene_gt_info" % (scene, name))
                grown = mask.copy()
                grown[1:, :] |= mask[:-1, :]
                grown[:-1, :] |= mask[1:, :]
                g2 = grown.copy()
                g2[:, 1:] |= grown[:, :-1]
                g2[:, :-1] |= grown[:, 1:]
                pts = models[gt["obj_id"]]["pts"]
                uv = misc.project_pts(pts, K, gt["cam_R_m2c"], gt["cam_t_m2c"])
                u = np.rint(uv[:, 0]).astype(int)
                v = np.rint(uv[:, 1]).astype(int)
                inside = (u >= 0) & (u < mask.shape[1]) & (v >= 0) & (v < mask.shape[0])
                vertices += int(inside.sum())
                off = int((~g2[v[inside], u[inside]]).sum())
                outside += off
                if off:
                    bad.append("scene %s %s: %d of the model's vertices project off its mask grown by a pixel" % (scene, name, off))
    print("bop_toolkit read %d models, %d scenes, %d images, %d objects in them" % (len(models), scenes, images, objects))
    print("model vertices projected into the images: %d; off their masks grown by one pixel: %d" % (vertices, outside))
    for b in bad[:20]:
        print("  " + b)
    print("OK" if not bad else "FAILED (%d problems)" % len(bad))
    return 0 if not bad else 1


if __name__ == "__main__":
    sys.exit(main())
