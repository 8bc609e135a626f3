#!/usr/bin/env python3
"""Explore a world mesh with the simulated vehicle, print the run's summary and save the map's mesh.

    PYTHONPATH=build/lib /usr/bin/python3 examples/explore_world.py \
        ../shared/data/aws_small_house_world/small_house_visual_mesh.ply -o out/house --mesh out/house.ply

The same as `vdbmap explore --world W -o RUNDIR` (same defaults; the world is cut at --ceiling and
closed with a flat ceiling there), written against the Python module: load the world, configure
the exploration, run it, read the map it wrote and mesh it. --camera-scale shrinks the camera's
resolution (same field of view) for a quick look.
"""
from __future__ import annotations

import argparse
import sys

import vdbmap
import vdbmap.sim as sim


def main() -> int:
    defaults = sim.ExplorationConfig()
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("world", help="world mesh (PLY, OBJ, OFF), metres, z up")
    parser.add_argument("-o", "--output", required=True, help="run folder to write")
    parser.add_argument("--mesh", help="also write the map's surface mesh here (.ply)")
    parser.add_argument("--drift", default="s1", choices=["s1", "s2", "s3", "s4"])
    parser.add_argument("--seed", type=int, default=defaults.seed)
    parser.add_argument("--voxel-size", type=float, default=defaults.voxel_size_m)
    parser.add_argument("--mode", default=str(defaults.mode), choices=["none", "submap", "all", "keyframes"])
    parser.add_argument("--max-time-s", type=float, default=defaults.max_time_s)
    parser.add_argument("--ceiling", type=float, default=2.5, help="cut and close the world here (0: keep it as is)")
    parser.add_argument("--camera-scale", type=float, default=1.0, help="fraction of the camera's 640x480 pixels")
    parser.add_argument("--overwrite", action="store_true", help="replace a run already in the folder")
    args = parser.parse_args()

    world_config = sim.WorldConfig()
    if args.ceiling > 0:
        world_config.ceiling_clip_z_m = args.ceiling
        world_config.cap_ceiling = True
    world = sim.World.load(args.world, world_config)

    config = sim.ExplorationConfig.for_world(world)  # the box and start `vdbmap explore` picks
    config.seed = args.seed  # before drift: a level name keeps the drift's seed
    config.drift = args.drift
    config.voxel_size_m = args.voxel_size
    config.mode = args.mode
    config.max_time_s = args.max_time_s
    config.set_budgets("counted")  # as `vdbmap explore`: the same arguments give the same run
    if args.camera_scale != 1.0:
        K = config.simulator.camera.intrinsics
        s = args.camera_scale
        config.simulator.camera.intrinsics = vdbmap.CameraIntrinsics(
            width=round(K.width * s), height=round(K.height * s), fx=K.fx * s, fy=K.fy * s, cx=K.cx * s, cy=K.cy * s)
    lo, hi = config.box
    print(f"{args.world}: {world.stats.triangles} triangles; box {lo.round(2)} - {hi.round(2)}; "
          f"start {config.start.round(2)}", file=sys.stderr)

    def progress(p: sim.ExplorationProgress) -> None:
        print(f"\rt {p.t_s:6.1f} s  frames {p.frames:5d}  clusters {p.clusters:3d}  path {p.path_length_m:6.1f} m  "
              f"{p.status}   ", end="", file=sys.stderr, flush=True)

    summary = sim.explore(world, config, args.output, overwrite=args.overwrite, progress=progress,
                          description=" ".join(sys.argv), report=lambda line: print(f"\n{line}", file=sys.stderr))
    print(file=sys.stderr)
    for key in ("finished", "exploration_time_s", "path_length_m", "coverage", "collisions", "loop_closures",
                "frames_total", "keyframes_kept", "accuracy_rmse_m", "completeness", "planner_ms_median"):
        print(f"{key}: {summary[key]}")

    if args.mesh:
        volume = vdbmap.TsdfVolume.load(f"{args.output}/map.vdb")
        vertices, triangles = vdbmap.extract_mesh(volume)
        vdbmap.write_ply_mesh(args.mesh, (vertices, triangles))
        print(f"wrote {args.mesh}: {len(vertices)} vertices, {len(triangles)} triangles")
    return 0


if __name__ == "__main__":
    sys.exit(main())
