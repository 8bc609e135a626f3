#!/usr/bin/env python3
"""Read a vdbmap map (.vdb) with Debian's pyopenvdb (python3-openvdb) beside our module.

    PYTHONPATH=build/lib /usr/bin/python3 examples/read_with_pyopenvdb.py out/map.vdb

A map file holds float grids "tsdf" (metres, background +truncation) and "weight" with the map's
metadata, so any OpenVDB reader can use it. This script lists what pyopenvdb sees, copies the
tsdf into a dense numpy array, and checks that it holds the values our module reads from the same
file (TsdfVolume.load).
"""
from __future__ import annotations

import argparse
import sys

import numpy as np
import pyopenvdb

import vdbmap


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("map", help="a map written by vdbmap (.vdb)")
    args = parser.parse_args()

    grids, metadata = pyopenvdb.readAll(args.map)
    print(f"{args.map}: metadata " + ", ".join(f"{k}={metadata[k]}" for k in sorted(metadata)))
    for grid in grids:
        lo, hi = grid.evalActiveVoxelBoundingBox()
        print(f"  grid {grid.name}: {type(grid).__name__}, {grid.activeVoxelCount()} active voxels, "
              f"voxel {grid.transform.voxelSize()[0]} m, index box {lo}..{hi}")

    tsdf = next(g for g in grids if g.name == "tsdf")
    lo, hi = tsdf.evalActiveVoxelBoundingBox()
    dense = np.full(tuple(h - l + 1 for l, h in zip(lo, hi)), tsdf.background, dtype=np.float32)
    tsdf.copyToArray(dense, ijk=lo)
    print(f"dense tsdf {dense.shape}: {np.count_nonzero(dense < 0)} voxels behind surfaces, "
          f"{np.count_nonzero((dense > 0) & (dense < tsdf.background))} in front within truncation")

    volume = vdbmap.TsdfVolume.load(args.map)
    ijk, values, _ = volume.known_voxels()
    same = np.array_equal(dense[tuple((ijk - np.array(lo)).T)], values)
    print(f"pyopenvdb and vdbmap read the same {len(values)} tsdf values: {same}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
