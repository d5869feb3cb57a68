#!/usr/bin/env python3
"""Writes a CARMEN laser log's FLASER scans as a ROS 2 bag (rosbag2, MCAP storage) with the
independent `rosbags` writer: sensor_msgs/msg/LaserScan on /scan (beam i at -pi/2 + i*pi/(n-1))
and the scan's corrected pose as nav_msgs/msg/Odometry on /odom, both stamped with the scan's
time. Used by python/tests/test_bag.py and by hand:

    python tools/carmen_to_bag.py LOG[.gz] OUT_BAG
"""
import gzip
import math
import pathlib
import sys

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore


def flaser(path):
    raw = path.read_bytes()
    text = gzip.decompress(raw) if raw[:2] == b"\x1f\x8b" else raw
    for line in text.decode().splitlines():
        f = line.split()
        if not f or f[0] != "FLASER":
            continue
        n = int(f[1])
        ranges = [float(v) for v in f[2 : 2 + n]]
        x, y, th = (float(v) for v in f[2 + n : 5 + n])
        yield ranges, x, y, th, float(f[8 + n])


def main():
    log, out = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    with Writer(out, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        scan_c = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts)
        odom_c = w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=ts)
        for ranges, x, y, th, t in flaser(log):
            sec = math.floor(t)
            stamp = T["builtin_interfaces/msg/Time"](sec=sec, nanosec=int(round((t - sec) * 1e9)))
            header = T["std_msgs/msg/Header"](stamp=stamp, frame_id="laser")
            n = len(ranges)
            scan = T["sensor_msgs/msg/LaserScan"](
                header=header, angle_min=-math.pi / 2, angle_max=math.pi / 2,
                angle_increment=math.pi / (n - 1), time_increment=0.0, scan_time=0.0,
                range_min=0.0, range_max=1e6, ranges=np.array(ranges, dtype=np.float32),
                intensities=np.array([], dtype=np.float32))
            q = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(th / 2), w=math.cos(th / 2))
            pose = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0), orientation=q)
            zero = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
            odom = T["nav_msgs/msg/Odometry"](
                header=T["std_msgs/msg/Header"](stamp=stamp, frame_id="odom"), child_frame_id="base_link",
                pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
                twist=T["geometry_msgs/msg/TwistWithCovariance"](
                    twist=T["geometry_msgs/msg/Twist"](linear=zero, angular=zero), covariance=np.zeros(36)))
            ns = max(0, int(round(t * 1e9)))
            w.write(odom_c, ns, ts.serialize_cdr(odom, "nav_msgs/msg/Odometry"))
            w.write(scan_c, ns, ts.serialize_cdr(scan, "sensor_msgs/msg/LaserScan"))


if __name__ == "__main__":
    main()
