#!/usr/bin/python3
"""Seed corpora for the fuzz targets (docs/fuzzing.md).

  make_corpus.py OUT_DIR [--vdb-generator PATH]    seeds from files, into OUT_DIR/<target>/
  make_corpus.py --update-committed                 rewrites fuzz/seeds/<target>/ (hand-made seeds)

The first copies small files (< 64 KiB, a few per target) from the repository's data/ and from
the shared data ($VDBMAP_SHARED_DATA, default ../shared/data; whatever is missing is skipped),
writes a ROS bag of the synthetic depth log with tests/io/make_test_bag.py (skipped without
python3-rosbag) and a map saved by vdbmap itself with fuzz_make_vdb_seed (when given). The
second writes the small synthetic seeds kept in the repository (a few KB in all): tiny logs and
dataset folders packed in fuzz_log's archive format, PNGs, a TUM trajectory, a TSPLIB instance,
a binary_compressed PCD. Everything is deterministic.
"""
import argparse
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MAX_BYTES = 64 * 1024
PER_TARGET = 4  # files taken from each data source per target

# fuzz_vdb: map.vdb, this separator, then map.exact.vdb (fuzz/fuzz_vdb.cpp).
EXACT_SEPARATOR = b'\n@@VDBMAP-FUZZ-EXACT@@\n'


# ---- synthetic files ------------------------------------------------------------------------

def png(width, height, bit_depth, color_type, samples, palette=None):
    """A PNG written by hand (no library): samples row-major, big-endian for 16 bits."""
    def chunk(kind, data):
        return struct.pack('>I', len(data)) + kind + data + struct.pack('>I', zlib.crc32(kind + data) & 0xffffffff)
    channels = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}[color_type]
    raw = b''
    i = 0
    for _ in range(height):
        row = b'\0'  # filter: none
        if bit_depth == 16:
            for _ in range(width * channels):
                row += struct.pack('>H', samples[i])
                i += 1
        else:
            for _ in range(width * channels):
                row += bytes([samples[i]])
                i += 1
        raw += row
    out = b'\x89PNG\r\n\x1a\n'
    out += chunk(b'IHDR', struct.pack('>IIBBBBB', width, height, bit_depth, color_type, 0, 0, 0))
    if palette:
        out += chunk(b'PLTE', bytes(palette))
    out += chunk(b'IDAT', zlib.compress(raw, 9))
    out += chunk(b'IEND', b'')
    return out


def depth_png(width=8, height=6, base_mm=1000):
    return png(width, height, 16, 0, [base_mm + 10 * u + v if (u + v) % 7 else 0
                                      for v in range(height) for u in range(width)])


def archive(files):
    """fuzz_log's input: '@@ <name>' lines, each followed by the file's bytes."""
    out = b''
    for name, data in files:
        if isinstance(data, str):
            data = data.encode()
        out += b'@@ ' + name.encode() + b'\n' + data
        if not data.endswith(b'\n'):
            out += b'\n'
    return out


SENSOR_DEPTH = ('{"kind": "depth", "width": 8, "height": 6, "fx": 6.0, "fy": 6.0, "cx": 3.5, "cy": 2.5,\n'
                ' "depth_scale": 0.001, "min_range_m": 0.1, "max_range_m": 5.0}\n')
SENSOR_POINTS = '{"kind": "points", "min_range_m": 0.1, "max_range_m": 20.0}\n'
FRAMES_HEADER = 'timestamp,file,tx,ty,tz,qx,qy,qz,qw\n'
IDENTITY_4x4 = '1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n'


def points_bin():
    return b''.join(struct.pack('<3f', 0.1 * k, -0.05 * k, 1.0 + 0.01 * k) for k in range(6))


def points_ply_ascii():
    return ('ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n'
            'end_header\n0 0 1\n0.1 0 1\n0 0.1 1.1\n')


def points_pcd_ascii():
    return ('VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\nHEIGHT 1\n'
            'VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA ascii\n0 0 1\n0.1 0 1\n0 0.1 1.1\n')


def pcd_binary_compressed():
    """x y z (float) and intensity (uint8, COUNT 2) of 3 points, LZF as literal runs only."""
    xs, ys, zs = [0.0, 0.1, 0.2], [0.0, 0.0, 0.1], [1.0, 1.0, 1.1]
    soa = struct.pack('<3f', *xs) + struct.pack('<3f', *ys) + struct.pack('<3f', *zs) + bytes([1, 2, 3, 4, 5, 6])
    lzf = b''
    for k in range(0, len(soa), 32):
        piece = soa[k:k + 32]
        lzf += bytes([len(piece) - 1]) + piece
    header = ('VERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 1\nTYPE F F F U\nCOUNT 1 1 1 2\nWIDTH 3\nHEIGHT 1\n'
              'VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA binary_compressed\n').encode()
    return header + struct.pack('<II', len(lzf), len(soa)) + lzf


def keyframe_store(version, frames, unit_id='0123456789abcdef0123456789abcdef'):
    """A keyframe store file (docs/formats.md, "map.keyframes") written by hand: frames are
    (id, stamp, kind, payload codes as bytes, count, camera or None, compressed); both poses a
    translation along x by the id in decimetres; unit 1 mm, stride 1. Version 3 ends each record
    with its CRC-32, versions 1 and 2 do not; version 1 has no unit id."""
    unit = b'' if version == 1 else unit_id.encode()
    out = b'VDBMAPKF' + struct.pack('<IIQ', version, len(unit), len(frames)) + unit
    for frame_id, stamp, kind, codes, count, camera, compressed in frames:
        pose = struct.pack('<16d', 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0.1 * frame_id, 0, 0, 1)  # column-major
        payload = zlib.compress(codes, 1) if compressed else codes
        record = struct.pack('<Qd', frame_id, stamp) + pose + pose
        record += struct.pack('<BBBBiId', 1, kind, int(compressed), int(camera is not None), 1, count, 0.001)
        if camera is not None:
            record += struct.pack('<ii4d', *camera)
        record += struct.pack('<Q', len(payload)) + payload
        out += record + (struct.pack('<I', zlib.crc32(record) & 0xffffffff) if version >= 3 else b'')
    return out


def keyframe_store_seeds():
    """fuzz_keyframes' seeds: a depth frame (8x6, row-delta 16-bit codes) and a point frame (two
    points, three 32-bit codes each) in every version, and raw (uncompressed) codes."""
    depth_mm = [1000 + 10 * u + 100 * v for v in range(6) for u in range(8)]
    deltas = []
    for v in range(6):
        row = depth_mm[8 * v:8 * v + 8]
        deltas += [row[0]] + [(row[u] - row[u - 1]) & 0xffff for u in range(1, 8)]
    depth_codes = struct.pack('<48H', *deltas)
    point_codes = struct.pack('<6i', 1000, 2000, 3000, 500, -250, 2000)
    camera = (8, 6, 6.0, 6.0, 3.5, 2.5)
    frames = [(0, 1.0, 0, depth_codes, 48, camera, True), (7, 1.5, 1, point_codes, 2, None, True)]
    raw = [(f[0], f[1], f[2], f[3], f[4], f[5], False) for f in frames]
    return {'store_v3.keyframes': keyframe_store(3, frames), 'store_v2.keyframes': keyframe_store(2, frames),
            'store_v1.keyframes': keyframe_store(1, frames), 'raw_v3.keyframes': keyframe_store(3, raw)}


def committed_seeds():
    """{target: {file name: bytes}}: the hand-made seeds kept under fuzz/seeds/."""
    # Stamps from 1 s on: a ROS bag index refuses time 0 (the bag seeds are made from this log).
    frames = FRAMES_HEADER + ('1.000000,d/0.png,0,0,0,0,0,0,1\n'
                              '1.066667,d/1.png,0.1,0,0,0,0,0,1\n'
                              '1.133333,d/0.png,0.2,0,0,0,0,0.0998334,0.9950042\n')
    depth_log = archive([
        ('sensor.json', SENSOR_DEPTH), ('frames.csv', frames),
        ('corrections/1.066667.txt', '# t tx ty tz qx qy qz qw\n1.000000 0 0 0 0 0 0 1\n1.066667 0.08 0 0 0 0 0 1\n'),
        ('corrections/1.133333.txt', '1.030000 0 0.01 0 0 0 0 1\n1.133333 0.18 0 0 0 0 0 1\n'),
        ('groundtruth.txt', '1.0 0 0 0 0 0 0 1\n1.066667 0.1 0 0 0 0 0 1\n'),
        ('d/0.png', depth_png()), ('d/1.png', depth_png(base_mm=1200))])
    points_log = archive([
        ('sensor.json', SENSOR_POINTS),
        ('frames.csv', FRAMES_HEADER + '1.0,p/0.bin,0,0,0,0,0,0,1\n1.1,p/1.ply,0,0,0.1,0,0,0,1\n'
                                       '1.2,p/2.pcd,0,0,0.2,0,0,0,1\n1.3,p/3.pcd,0,0,0.3,0,0,0,1\n'),
        ('corrections/1.300000.txt', '1.0 0 0 0 0 0 0 1\n1.3 0 0 0.25 0 0 0 1\n'),
        ('p/0.bin', points_bin()), ('p/1.ply', points_ply_ascii()), ('p/2.pcd', points_pcd_ascii()),
        ('p/3.pcd', pcd_binary_compressed())])
    seven_scenes = archive([
        ('camera-intrinsics.txt', '6 0 3.5\n0 6 2.5\n0 0 1\n'),
        ('frame-000000.depth.png', depth_png()), ('frame-000000.pose.txt', IDENTITY_4x4),
        ('frame-000001.depth.png', depth_png(base_mm=900)),
        ('frame-000001.pose.txt', '1 0 0 0.1\n0 1 0 0\n0 0 1 0\n0 0 0 1\n')])
    tum = archive([
        ('sensor.json', SENSOR_DEPTH),
        ('depth.txt', '# timestamp filename\n10.00 depth/a.png\n10.03 depth/b.png\n'),
        ('groundtruth.txt', '9.99 0 0 0 0 0 0 1\n10.02 0.01 0 0 0 0 0 1\n10.05 0.02 0 0 0 0 0 1\n'),
        ('depth/a.png', depth_png()), ('depth/b.png', depth_png(base_mm=1100))])
    iclnuim = archive([('pose.txt', '0 0 0 0 0 0 1\n0.1 0 0 0 0 0 1\n'), ('depth/1.png', depth_png()),
                       ('depth/2.png', depth_png(base_mm=800))])
    redwood = archive([('depth/000000.png', depth_png()), ('depth/000001.png', depth_png(base_mm=1300)),
                       ('trajectory.log', '0 0 1\n' + IDENTITY_4x4 + '1 1 2\n' + IDENTITY_4x4),
                       ('camera.json', '{"width": 8, "height": 6, "intrinsic_matrix": [6, 0, 0, 0, 6, 0, 3.5, 2.5, 1]}\n')])
    replica = archive([('cam_params.json', '{"camera": {"w": 8, "h": 6, "fx": 6.0, "fy": 6.0, "cx": 3.5, "cy": 2.5, '
                                           '"scale": 6553.5}}\n'),
                       ('traj.txt', '1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n1 0 0 0.1 0 1 0 0 0 0 1 0 0 0 0 1\n'),
                       ('results/depth000000.png', depth_png()), ('results/depth000001.png', depth_png(base_mm=700))])

    gray8 = png(4, 3, 8, 0, list(range(0, 240, 20)))
    palette = png(4, 2, 8, 3, [0, 1, 2, 1, 0, 2, 1, 0], palette=[0, 0, 0, 255, 0, 0, 0, 255, 0])
    rgba16 = png(2, 2, 16, 6, [k * 4000 for k in range(16)])
    tum_traj = ('# timestamp tx ty tz qx qy qz qw\n'
                '1305031102.1758 1.3405 0.6266 1.6575 0.6574 0.6126 -0.2949 -0.3248\n'
                '1305031102.2158 1.3303 0.6256 1.6464 0.6579 0.6161 -0.2932 -0.3189\n'
                '1305031102.2758 1.3160 0.6254 1.6302 0.6609 0.6199 -0.2893 -0.3086\n')
    tsplib = ('NAME: tiny4\nTYPE: ATSP\nCOMMENT: hand-made seed\nDIMENSION: 4\nEDGE_WEIGHT_TYPE: EXPLICIT\n'
              'EDGE_WEIGHT_FORMAT: FULL_MATRIX\nEDGE_WEIGHT_SECTION\n9999 3 5 48\n 3 9999 3 48\n5 3 9999\n 72\n'
              '48 48 74 9999\nEOF\n')
    return {
        'fuzz_log': {'depth_log.archive': depth_log, 'points_log.archive': points_log,
                     '7scenes.archive': seven_scenes, 'tum.archive': tum, 'iclnuim.archive': iclnuim,
                     'redwood.archive': redwood, 'replica.archive': replica},
        'fuzz_png_depth': {'depth16.png': depth_png(), 'gray8.png': gray8, 'palette.png': palette,
                           'rgba16.png': rgba16},
        'fuzz_pcd': {'binary_compressed.pcd': pcd_binary_compressed(), 'ascii.pcd': points_pcd_ascii().encode()},
        'fuzz_tum': {'trajectory.txt': tum_traj.encode()},
        'fuzz_tsplib': {'tiny4.atsp': tsplib.encode()},
        'fuzz_keyframes': keyframe_store_seeds(),
    }


# ---- seeds from files -------------------------------------------------------------------------

def small_files(folder, extensions, limit=PER_TARGET, names=None):
    """Up to `limit` files under `folder` smaller than MAX_BYTES, by extension (sorted, deterministic)."""
    found = []
    if not os.path.isdir(folder):
        return found
    for dirpath, dirnames, filenames in os.walk(folder):
        dirnames.sort()
        for f in sorted(filenames):
            path = os.path.join(dirpath, f)
            if names is not None and f not in names:
                continue
            if names is None and not f.lower().endswith(extensions):
                continue
            if os.path.getsize(path) < MAX_BYTES:
                found.append(path)
    return found[:limit]


def copy_seeds(out, target, paths):
    os.makedirs(os.path.join(out, target), exist_ok=True)
    for p in paths:
        rel = os.path.relpath(p, '/').replace(os.sep, '_')
        shutil.copyfile(p, os.path.join(out, target, rel))


def write_seed(out, target, name, data):
    os.makedirs(os.path.join(out, target), exist_ok=True)
    with open(os.path.join(out, target, name), 'wb') as f:
        f.write(data)


def unpack_archive(data, folder):
    """The inverse of archive(), for the tools that want a real folder (make_test_bag.py)."""
    parts = data.split(b'\n@@ ')
    parts[0] = parts[0][3:]  # the leading '@@ '
    for part in parts:
        name, _, body = part.partition(b'\n')
        path = os.path.join(folder, name.decode())
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, 'wb') as f:
            f.write(body)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('out', nargs='?', help='folder for the seed corpora (one sub-folder per target)')
    p.add_argument('--vdb-generator', help='fuzz_make_vdb_seed from a VDBMAP_FUZZ build')
    p.add_argument('--update-committed', action='store_true', help='rewrite fuzz/seeds/ and stop')
    a = p.parse_args()
    seeds = committed_seeds()
    if a.update_committed:
        for target, files in seeds.items():
            folder = os.path.join(ROOT, 'fuzz', 'seeds', target)
            shutil.rmtree(folder, ignore_errors=True)
            for name, data in files.items():
                write_seed(os.path.join(ROOT, 'fuzz', 'seeds'), target, name, data)
        total = sum(len(d) for files in seeds.values() for d in files.values())
        print(f'fuzz/seeds: {sum(len(f) for f in seeds.values())} files, {total} bytes')
        return 0
    if not a.out:
        p.error('give OUT_DIR or --update-committed')
    out = a.out
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    data = os.path.join(ROOT, 'data')
    shared = os.environ.get('VDBMAP_SHARED_DATA', os.path.join(ROOT, '..', 'shared', 'data'))

    for source in (data, shared):
        copy_seeds(out, 'fuzz_ply', small_files(source, ('.ply',)))
        copy_seeds(out, 'fuzz_pcd', small_files(source, ('.pcd',)))
        copy_seeds(out, 'fuzz_mesh_text', small_files(source, ('.obj', '.off')))
        copy_seeds(out, 'fuzz_tsplib', small_files(source, ('.atsp', '.tsp')))
        copy_seeds(out, 'fuzz_png_depth', small_files(source, ('.png',), limit=2))
        copy_seeds(out, 'fuzz_tum', small_files(source, (), names={'groundtruth.txt', 'pose.txt', 'traj.txt'}, limit=2))
    # The fuzz_log archive format for one real dataset folder with small files (ICL-NUIM's pose.txt
    # and Redwood's trajectory.log lists, without their 300 KB images).
    for rel, names in (('open3d_testdata_redwood_tum/RGBD', ('trajectory.log',)),
                       ('iclnuim_livingroom_5frames_slambook2', ('pose.txt',))):
        folder = os.path.join(shared, rel)
        files = [(n, open(os.path.join(folder, n), 'rb').read()) for n in names if os.path.isfile(os.path.join(folder, n))]
        if files:
            write_seed(out, 'fuzz_log', rel.replace('/', '_') + '.archive',
                       archive(files + [('depth/1.png', depth_png()), ('depth/000000.png', depth_png())]))

    # A bag written by ROS's own library from the synthetic depth log.
    with tempfile.TemporaryDirectory() as tmp:
        log = os.path.join(tmp, 'log')
        unpack_archive(seeds['fuzz_log']['depth_log.archive'], log)
        bag = os.path.join(tmp, 'seed.bag')
        script = os.path.join(ROOT, 'tests', 'io', 'make_test_bag.py')
        for variant, extra in (('odometry', []), ('transform_32f', ['--pose-type', 'transform', '--encoding', '32FC1'])):
            r = subprocess.run(['/usr/bin/python3', script, log, bag] + extra, capture_output=True, text=True)
            if r.returncode == 0 and os.path.getsize(bag) < MAX_BYTES:
                write_seed(out, 'fuzz_bag', variant + '.bag', open(bag, 'rb').read())
            else:
                print(f'make_corpus: no {variant} bag seed ({(r.stdout + r.stderr).strip()[:200]})', file=sys.stderr)
                break

    # A map saved by vdbmap itself, alone and with its exact companion.
    if a.vdb_generator:
        with tempfile.TemporaryDirectory() as tmp:
            vdb = os.path.join(tmp, 'map.vdb')
            r = subprocess.run([a.vdb_generator, vdb], capture_output=True, text=True)
            exact = os.path.join(tmp, 'map.exact.vdb')
            if r.returncode == 0 and os.path.isfile(vdb):
                map_bytes = open(vdb, 'rb').read()
                write_seed(out, 'fuzz_vdb', 'map.vdb', map_bytes)
                if os.path.isfile(exact):
                    write_seed(out, 'fuzz_vdb', 'map_with_exact.vdb', map_bytes + EXACT_SEPARATOR + open(exact, 'rb').read())
            else:
                print(f'make_corpus: no vdb seed ({r.stderr.strip()[:200]})', file=sys.stderr)
    # A plain OpenVDB file (not a vdbmap map) from Debian's pyopenvdb, when installed.
    try:
        import pyopenvdb as vdb
        with tempfile.TemporaryDirectory() as tmp:
            grid = vdb.FloatGrid(0.5)
            grid.name = 'tsdf'
            acc = grid.getAccessor()
            for k in range(4):
                acc.setValueOn((k, 0, k), 0.1 * k)
            path = os.path.join(tmp, 'plain.vdb')
            vdb.write(path, grids=[grid])
            write_seed(out, 'fuzz_vdb', 'pyopenvdb_plain.vdb', open(path, 'rb').read())
    except Exception as e:  # ImportError, or a pyopenvdb without these calls
        print(f'make_corpus: no pyopenvdb seed ({e})', file=sys.stderr)

    for target in sorted(os.listdir(out)):
        files = os.listdir(os.path.join(out, target))
        size = sum(os.path.getsize(os.path.join(out, target, f)) for f in files)
        print(f'make_corpus: {target}: {len(files)} seeds, {size} bytes')
    return 0


if __name__ == '__main__':
    sys.exit(main())
