#!/usr/bin/env python3
"""Integrate a log or dataset folder into a TSDF map and save it with its mesh.

    PYTHONPATH=build/lib /usr/bin/python3 examples/integrate_log.py \
        ../shared/data/iclnuim_livingroom_5frames_slambook2 -o out/map.vdb --mesh out/mesh.ply

The same as `vdbmap integrate LOG -o MAP --mesh MESH` (same defaults, same map bit for bit), written
against the Python module: open the sequence, configure a Mapper, replay, save, mesh.
"""
from __future__ import annotations

import argparse
import sys

import vdbmap


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("log", help="log folder (sensor.json + frames.csv) or a dataset folder")
    parser.add_argument("-o", "--output", required=True, help="map to write (.vdb)")
    parser.add_argument("--mesh", help="also write the surface mesh (.ply)")
    parser.add_argument("--voxel-size", type=float, default=vdbmap.TsdfConfig().voxel_size_m)
    parser.add_argument("--mode", default=str(vdbmap.MapperConfig().mode),
                        choices=["none", "submap", "all", "keyframes"])
    parser.add_argument("--stride", type=int, default=1, help="integrate every k-th frame")
    args = parser.parse_args()

    source = vdbmap.open_dataset(args.log)
    print(f"{args.log}: {len(source)} frames ({source.format})", file=sys.stderr)

    config = vdbmap.MapperConfig(mode=args.mode)
    config.tsdf.voxel_size_m = args.voxel_size
    config.integrator.min_range_m = source.sensor.min_range_m  # as the CLI: the sensor's ranges
    config.integrator.max_range_m = source.sensor.max_range_m
    mapper = vdbmap.Mapper(config)

    def progress(done: int, total: int) -> None:
        print(f"\rintegrated {done}/{total}", end="", file=sys.stderr, flush=True)

    result = vdbmap.replay_log(source, mapper, vdbmap.ReplayConfig(frame_stride=args.stride, progress=progress))
    print(file=sys.stderr)

    volume = mapper.volume()
    volume.save(args.output)
    print(f"integrated {result.frames_integrated} of {result.frames_total} frames, "
          f"{result.ms_per_frame_median:.1f} ms/frame median; {result.correction_events} correction events, "
          f"{mapper.keyframes_kept} keyframes kept")
    print(f"wrote {args.output}: {volume.active_voxel_count} voxels")
    if args.mesh:
        vertices, triangles = vdbmap.extract_mesh(volume)
        vdbmap.write_ply_mesh(args.mesh, (vertices, triangles))
        print(f"wrote {args.mesh}: {len(vertices)} vertices, {len(triangles)} triangles")
    return 0


if __name__ == "__main__":
    sys.exit(main())
