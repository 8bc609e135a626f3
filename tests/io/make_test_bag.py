#!/usr/bin/env python3
"""Writes a ROS1 bag from a vdbmap log folder with ROS's own rosbag library (python3-rosbag), as a
robot's recording would hold it: depth images, the camera's CameraInfo, body poses and loop
corrections as nav_msgs/Path. Test input for vdbmap's bag reader (tests/vdbmap/test_ros_bag.cpp).

  make_test_bag.py LOG OUT.bag [options]

Body poses are the log's camera poses times the inverse extrinsic (camera = body x T_B_S), at
the frames' stamps, or with --analytic-odometry a body moving at 0.5 m/s along x turning at
0.2 rad/s, published every 30 ms from --odometry-start on. Each corrections/<stamp>.txt becomes
one Path message at its stamp (every --every-th pose). Exit status 77 when rosbag is missing.
"""
import argparse
import csv
import glob
import json
import math
import os
import sys

try:
    import numpy as np
    import rosbag
    import rospy
    from geometry_msgs.msg import PoseStamped, TransformStamped
    from nav_msgs.msg import Odometry, Path
    from PIL import Image as PilImage
    from sensor_msgs.msg import CameraInfo, Image
except ImportError as e:
    print(f'skipped: {e} (scripts/test.sh installs python3-rosbag and its message packages)')
    sys.exit(77)


def quat_to_matrix(x, y, z, w):
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def matrix_to_quat(R):
    w = math.sqrt(max(0.0, 1 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
    x = math.copysign(math.sqrt(max(0.0, 1 + R[0, 0] - R[1, 1] - R[2, 2])) / 2, R[2, 1] - R[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1 - R[0, 0] + R[1, 1] - R[2, 2])) / 2, R[0, 2] - R[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1 - R[0, 0] - R[1, 1] + R[2, 2])) / 2, R[1, 0] - R[0, 1])
    return x, y, z, w


def pose_matrix(t, q):
    T = np.eye(4)
    T[:3, :3] = quat_to_matrix(*q)
    T[:3, 3] = t
    return T


OFFSET = [0.0]


def stamp(t):
    return rospy.Time.from_sec(t + OFFSET[0])


def main():
    p = argparse.ArgumentParser()
    p.add_argument('log')
    p.add_argument('bag')
    p.add_argument('--encoding', default='16UC1', help='16UC1, 32FC1, or anything else to test refusals')
    p.add_argument('--pose-type', default='odometry', choices=['odometry', 'pose', 'transform'])
    p.add_argument('--extrinsic', default='0,0,0,0,0,0,1', help='T_body_camera x,y,z,qx,qy,qz,qw')
    p.add_argument('--analytic-odometry', action='store_true')
    p.add_argument('--odometry-start', type=float, default=0.0)
    p.add_argument('--every', type=int, default=1, help='keep every k-th pose of each correction')
    p.add_argument('--no-camera-info', action='store_true')
    p.add_argument('--distorted', action='store_true', help='plumb_bob with non-zero coefficients')
    p.add_argument('--swap-stamps', action='store_true', help='frames 1 and 2 out of order')
    p.add_argument('--stride', type=int, default=1, help='keep every k-th frame')
    p.add_argument('--time-offset', type=float, default=0.0,
                   help='added to every stamp (ROS bags cannot hold time 0, which logs start at)')
    a = p.parse_args()
    OFFSET[0] = a.time_offset

    sensor = json.load(open(os.path.join(a.log, 'sensor.json')))
    rows = list(csv.DictReader(open(os.path.join(a.log, 'frames.csv'))))[::a.stride]
    e = [float(v) for v in a.extrinsic.split(',')]
    E_inv = np.linalg.inv(pose_matrix(e[:3], e[3:]))

    identity = e == [0, 0, 0, 0, 0, 0, 1]

    def body(t, q):
        """The body pose (translation, quaternion) of a camera pose; with no extrinsic the numbers
        pass through untouched, so that the bag's poses are the log's bit for bit."""
        if identity:
            return t, q
        T = pose_matrix(t, q) @ E_inv
        return list(T[:3, 3]), list(matrix_to_quat(T[:3, :3]))

    def fill_pose(msg_pose, T):
        t, q = T
        msg_pose.position.x, msg_pose.position.y, msg_pose.position.z = t
        msg_pose.orientation.x, msg_pose.orientation.y, msg_pose.orientation.z, msg_pose.orientation.w = q

    def pose_message(t, T):
        if a.pose_type == 'odometry':
            m = Odometry()
            m.header.stamp = stamp(t)
            fill_pose(m.pose.pose, T)
        elif a.pose_type == 'pose':
            m = PoseStamped()
            m.header.stamp = stamp(t)
            fill_pose(m.pose, T)
        else:
            m = TransformStamped()
            m.header.stamp = stamp(t)
            m.transform.translation.x, m.transform.translation.y, m.transform.translation.z = T[0]
            m.transform.rotation.x, m.transform.rotation.y, m.transform.rotation.z, m.transform.rotation.w = T[1]
        return m

    received = [float(r['timestamp']) for r in rows]  # when the recorder got each message
    stamps = list(received)                            # what each message's header says
    if a.swap_stamps:
        stamps[1], stamps[2] = stamps[2], stamps[1]
    with rosbag.Bag(a.bag, 'w') as bag:
        if not a.no_camera_info:
            info = CameraInfo()
            info.header.stamp = stamp(stamps[0])
            info.width, info.height = sensor['width'], sensor['height']
            info.K = [sensor['fx'], 0, sensor['cx'], 0, sensor['fy'], sensor['cy'], 0, 0, 1]
            info.distortion_model = 'plumb_bob'
            info.D = [0.1, 0, 0, 0, 0] if a.distorted else [0.0] * 5
            bag.write('/camera/depth/camera_info', info, stamp(stamps[0]))
        for t, t_received, r in zip(stamps, received, rows):
            raw = np.array(PilImage.open(os.path.join(a.log, r['file'])), dtype=np.uint16)
            invalid = sensor.get('depth_invalid_value', 0)  # e.g. 7-Scenes' 65535: 0 in a ROS depth image
            if invalid:
                raw[raw == invalid] = 0
            img = Image()
            img.header.stamp = stamp(t)
            img.height, img.width = raw.shape
            img.encoding = a.encoding
            if a.encoding == '32FC1':
                data = (raw.astype(np.float32) * np.float32(sensor['depth_scale']))
                data[raw == 0] = np.nan
                img.step = img.width * 4
            else:
                data = raw
                img.step = img.width * 2
            img.data = data.astype('<f4' if a.encoding == '32FC1' else '<u2').tobytes()
            bag.write('/camera/depth/image_rect_raw', img, stamp(t_received))
            if not a.analytic_odometry:
                T = body([float(r[k]) for k in ('tx', 'ty', 'tz')], [float(r[k]) for k in ('qx', 'qy', 'qz', 'qw')])
                bag.write('/odometry', pose_message(t, T), stamp(t_received))
        if a.analytic_odometry:
            t = a.odometry_start
            while t <= stamps[-1] + 0.1:
                yaw = 0.2 * t
                bag.write('/odometry', pose_message(t, ([0.5 * t, 0.0, 1.0], [0, 0, math.sin(yaw / 2), math.cos(yaw / 2)])),
                          stamp(t))
                t = round(t + 0.03, 9)
        for f in sorted(glob.glob(os.path.join(a.log, 'corrections', '*.txt'))):
            event = float(os.path.basename(f)[:-4])
            path = Path()
            path.header.stamp = stamp(event)
            lines = [l.split() for l in open(f) if l.strip() and not l.startswith('#')]
            for k, v in enumerate(lines):
                if k % a.every:
                    continue
                ps = PoseStamped()
                ps.header.stamp = stamp(float(v[0]))
                fill_pose(ps.pose, body([float(x) for x in v[1:4]], [float(x) for x in v[4:8]]))
                path.poses.append(ps)
            bag.write('/loop_fusion/pose_graph_path', path, stamp(event))


if __name__ == '__main__':
    main()
