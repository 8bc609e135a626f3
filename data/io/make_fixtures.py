#!/usr/bin/env python3
"""Writes the small I/O test fixtures in this folder (see PROVENANCE.md). Deterministic: running
it again reproduces the same bytes. Standard library only."""
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))

# A unit cube [0,1]^3 with 6 quad faces (12 triangles once fanned), counter-clockwise seen from outside.
CUBE_V = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
CUBE_F = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]

# Five points, one of them NaN (an invalid return), for the point-cloud readers.
POINTS = [(0.5, -0.25, 1.0), (1.5, 2.0, 3.25), (-1.0, 0.0, 0.125), (float("nan"), float("nan"), float("nan")), (0.0, 0.0, 4.0)]


def write(name, data):
    mode = "wb" if isinstance(data, bytes) else "w"
    with open(os.path.join(HERE, name), mode, newline="\n" if mode == "w" else None) as f:
        f.write(data)


def cube_ply_ascii():
    # Extra vertex properties (a colour) and an extra element after the faces must be skipped.
    s = ["ply", "format ascii 1.0", "comment vdbmap test fixture: unit cube", "element vertex 8",
         "property float x", "property float y", "property float z",
         "property uchar red", "property uchar green", "property uchar blue",
         "element face 6", "property list uchar int vertex_indices",
         "element edge 1", "property int vertex1", "property int vertex2", "end_header"]
    s += ["%g %g %g 255 0 0" % v for v in CUBE_V]
    s += ["4 " + " ".join(str(i) for i in f) for f in CUBE_F]
    s += ["0 1"]
    write("cube_ascii.ply", "\n".join(s) + "\n")


def cube_ply_binary(endian, name):
    e = "<" if endian == "little" else ">"
    head = ["ply", "format binary_%s_endian 1.0" % endian, "comment vdbmap test fixture: unit cube",
            "element vertex 8", "property double x", "property double y", "property double z",
            "property uchar alpha",
            "element face 6", "property list uchar uint vertex_index", "property int flags", "end_header"]
    body = b""
    for v in CUBE_V:
        body += struct.pack(e + "dddB", *v, 200)
    for f in CUBE_F:
        body += struct.pack(e + "B4Ii", 4, *f, -7)
    write(name, ("\n".join(head) + "\n").encode() + body)


def cube_obj():
    s = ["# vdbmap test fixture: unit cube, mixed corner forms and a negative index", "o cube", "mtllib none.mtl"]
    s += ["v %g %g %g" % v for v in CUBE_V]
    s += ["vt 0 0", "vn 0 0 1", "g sides", "s off"]
    forms = ["{}", "{}/1", "{}//1", "{}/1/1"]
    for k, f in enumerate(CUBE_F[:-1]):
        s.append("f " + " ".join(forms[(k + j) % 4].format(i + 1) for j, i in enumerate(f)))
    # the last face with indices relative to the 8 vertices read so far (-8 is vertex 0)
    s.append("f " + " ".join(str(i - 8) for i in CUBE_F[-1]))
    write("cube.obj", "\n".join(s) + "\n")


def cube_off():
    s = ["OFF", "# vdbmap test fixture: unit cube, counts on their own line", "8 6 12"]
    s += ["%g %g %g" % v for v in CUBE_V]
    s += ["4 " + " ".join(str(i) for i in f) + "  255 255 255" for f in CUBE_F]
    write("cube.off", "\n".join(s) + "\n")


def points_pcd_ascii():
    head = ["# .PCD v0.7 - vdbmap test fixture", "VERSION 0.7", "FIELDS x y z intensity", "SIZE 4 4 4 4",
            "TYPE F F F F", "COUNT 1 1 1 1", "WIDTH 5", "HEIGHT 1", "VIEWPOINT 0 0 0 1 0 0 0", "POINTS 5", "DATA ascii"]
    body = ["%r %r %r 7" % p if p[0] == p[0] else "nan nan nan 7" for p in POINTS]
    write("points_ascii.pcd", "\n".join(head + body) + "\n")


def points_pcd_binary():
    # Field order differs from x y z and x is preceded by a 3-element descriptor, to test offsets.
    head = ["# .PCD v0.7 - vdbmap test fixture", "VERSION 0.7", "FIELDS rgb z desc y x", "SIZE 4 4 2 8 4",
            "TYPE U F I F F", "COUNT 1 1 3 1 1", "WIDTH 5", "HEIGHT 1", "VIEWPOINT 0 0 0 1 0 0 0", "POINTS 5", "DATA binary"]
    body = b""
    for p in POINTS:
        body += struct.pack("<Ifhhhdf", 0x00FF00, p[2], 1, 2, 3, p[1], p[0])
    write("points_binary.pcd", ("\n".join(head) + "\n").encode() + body)


def points_ply_binary_be():
    head = ["ply", "format binary_big_endian 1.0", "comment vdbmap test fixture: 5 points", "element vertex 5",
            "property float x", "property float y", "property float z", "property short label", "end_header"]
    body = b"".join(struct.pack(">fffh", *p, 3) for p in POINTS)
    write("points_binary_be.ply", ("\n".join(head) + "\n").encode() + body)


def points_bin():
    write("points.bin", b"".join(struct.pack("<fff", *p) for p in POINTS))


if __name__ == "__main__":
    cube_ply_ascii()
    cube_ply_binary("little", "cube_binary_le.ply")
    cube_ply_binary("big", "cube_binary_be.ply")
    cube_obj()
    cube_off()
    points_pcd_ascii()
    points_pcd_binary()
    points_ply_binary_be()
    points_bin()
