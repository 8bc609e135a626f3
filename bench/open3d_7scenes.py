#!/usr/bin/python3
"""Open3D's ScalableTSDFVolume on the same 500 7-Scenes frames, timed like `vdbmap integrate`
(integration only, file reading excluded). Debian package python3-open3d; not a CI dependency.

    /usr/bin/python3 bench/open3d_7scenes.py ../shared/data/7scenes_redkitchen_tsdf_fusion_python 0.05
prints one JSON line: {"peer", "voxel_size_m", "frames", "ms_per_frame_median", "ms_per_frame_p90",
"ms_per_frame_p99", "ms_per_frame_max", "integrate_s"} (what `vdbmap bench latency --peer` reads).
"""
import json
import sys
import time
from pathlib import Path

import numpy as np
import open3d as o3d


def main():
    root = Path(sys.argv[1])
    voxel = float(sys.argv[2]) if len(sys.argv) > 2 else 0.05
    K = np.loadtxt(root / "camera-intrinsics.txt")
    intr = o3d.camera.PinholeCameraIntrinsic(640, 480, K[0, 0], K[1, 1], K[0, 2], K[1, 2])
    volume = o3d.pipelines.integration.ScalableTSDFVolume(
        voxel_length=voxel, sdf_trunc=3 * voxel,
        color_type=o3d.pipelines.integration.TSDFVolumeColorType.NoColor)
    depths = sorted((root / "depth").glob("frame-*.depth.png"))
    times = []
    for d in depths:
        pose = np.loadtxt(root / "pose" / d.name.replace(".depth.png", ".pose.txt"))
        depth_np = np.asarray(o3d.io.read_image(str(d))).copy()
        depth_np[depth_np == 65535] = 0  # 7-Scenes marks invalid depth with 65535 too
        depth = o3d.geometry.Image(depth_np)
        color = o3d.geometry.Image(np.zeros((480, 640, 3), dtype=np.uint8))
        rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
            color, depth, depth_scale=1000.0, depth_trunc=5.0, convert_rgb_to_intensity=False)
        t0 = time.perf_counter()
        volume.integrate(rgbd, intr, np.linalg.inv(pose))
        times.append(time.perf_counter() - t0)
    ms = 1e3 * np.asarray(times)
    print(json.dumps({"peer": "open3d.ScalableTSDFVolume", "voxel_size_m": voxel, "frames": len(times),
                      "ms_per_frame_median": float(np.median(ms)), "ms_per_frame_p90": float(np.percentile(ms, 90)),
                      "ms_per_frame_p99": float(np.percentile(ms, 99)), "ms_per_frame_max": float(ms.max()),
                      "integrate_s": float(ms.sum() / 1e3)}))


if __name__ == "__main__":
    main()
