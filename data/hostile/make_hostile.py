#!/usr/bin/env python3
"""Writes the hostile inputs of tests/tools/test_cli_hostile.cpp (standard library only,
deterministic: running it again gives the same bytes). Each is a few hundred bytes at most and
declares or asks for far more than it holds; see PROVENANCE.md for what each must produce."""
from __future__ import annotations

import pathlib
import struct
import zlib

HERE = pathlib.Path(__file__).resolve().parent
HEADER = "timestamp,file,tx,ty,tz,qx,qy,qz,qw\n"
SENSOR = ('{"kind": "depth", "width": 8, "height": 6, "fx": 6.0, "fy": 6.0, "cx": 3.5, "cy": 2.5, '
          '"depth_scale": 0.001}\n')


def write(rel: str, data: bytes | str) -> None:
    path = HERE / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data.encode() if isinstance(data, str) else data)


def png_chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)


def png(width: int, height: int, rows: bytes) -> bytes:
    ihdr = struct.pack(">IIBBBBB", width, height, 16, 0, 0, 0, 0)  # 16-bit gray
    return (b"\x89PNG\r\n\x1a\n" + png_chunk(b"IHDR", ihdr) + png_chunk(b"IDAT", zlib.compress(rows)) +
            png_chunk(b"IEND", b""))


def depth_png() -> bytes:
    """An 8 x 6 wall at 1.5 m (millimetres)."""
    row = b"\x00" + struct.pack(">H", 1500) * 8
    return png(8, 6, row * 6)


def log(folder: str, frames: str, sensor: str = SENSOR, pngs: dict[str, bytes] | None = None) -> None:
    write(f"{folder}/sensor.json", sensor)
    write(f"{folder}/frames.csv", HEADER + frames)
    for name, data in (pngs or {"depth/000000.png": depth_png()}).items():
        write(f"{folder}/{name}", data)


def main() -> None:
    ok = "0.0,depth/000000.png,0,0,0,0,0,0,1\n"
    log("valid_log", ok)
    # 1: one number that would ask for unbounded work.
    log("far_pose_log", "0.0,depth/000000.png,1e9,0,0,0,0,0,1\n")
    # 2: sizes declared by headers.
    log("huge_png_log", ok, pngs={"depth/000000.png": png(100000, 100000, b"")})
    write("huge_vertex_count.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n"
                                   "property float x\nproperty float y\nproperty float z\nend_header\n")
    write("huge_point_count.pcd", "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                                  "WIDTH 1000000000000\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1000000000000\n"
                                  "DATA binary\n")
    write("points_huge_pcd_log/sensor.json", '{"kind": "points"}\n')
    write("points_huge_pcd_log/frames.csv", HEADER + "0.0,../huge_point_count.pcd,0,0,0,0,0,0,1\n")
    write("dimension_20000.atsp", "NAME: hostile\nTYPE: ATSP\nDIMENSION: 20000\nEDGE_WEIGHT_TYPE: EXPLICIT\n"
                                  "EDGE_WEIGHT_FORMAT: FULL_MATRIX\nEDGE_WEIGHT_SECTION\n0 1 2\nEOF\n")
    write("nan_vertex.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                            "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                            "0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n")
    # A .vdb header that declares metadata the file does not hold (OpenVDB alone allocated 20 GB).
    header = struct.pack("<QIIIB", 0x56444220, 224, 10, 0, 1) + b"0" * 36
    write("cut_map.vdb", header + struct.pack("<i", 12) + struct.pack("<I", 3_000_000_000))
    # 2: a 640 x 480 wall at 4 m: with 0.1 mm voxels its leaves would take terabytes (refused by the
    # memory estimate on any machine).
    wide = ('{"kind": "depth", "width": 640, "height": 480, "fx": 525.0, "fy": 525.0, "cx": 319.5, '
            '"cy": 239.5, "depth_scale": 0.001}\n')
    log("wide_frame_log", ok, sensor=wide,
        pngs={"depth/000000.png": png(640, 480, (b"\x00" + struct.pack(">H", 4000) * 640) * 480)})
    # 7: what the docs forbid.
    log("extra_column_log", "0.0,depth/000000.png,0,0,0,0,0,0,1,7\n")
    log("negative_fx_log", ok, sensor=SENSOR.replace('"fx": 6.0', '"fx": -6.0'))
    log("header_only_log", "")
    # 5: DBL_MAX, printed short.
    log("dbl_max_scale_log", ok, sensor=SENSOR.replace('"depth_scale": 0.001', '"depth_scale": 1.7976931348623157e308'))
    # 5: control bytes in a file name are echoed escaped.
    log("control_bytes_log", "0.0,depth/\x1b[31mred.png,0,0,0,0,0,0,1\n")


if __name__ == "__main__":
    main()
