#!/usr/bin/env python3
"""Writes a ROS 2 bag (rosbag2, MCAP storage) from a steernav TUM-layout folder, with the
independent `rosbags` writer: the frames as sensor_msgs/msg/Image (rgb8, or mono8) or
CompressedImage (png), the calib.toml as CameraInfo, stamped by rgb.txt. Used by the tests
(python/tests/test_bag.py) and by hand:

    python tools/make_bag.py SYNTH_DIR OUT_BAG [--compressed] [--mono]
"""
import argparse
import pathlib
import tomllib

import numpy as np
from PIL import Image as PilImage
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore


def frames(folder):
    for line in (folder / "rgb.txt").read_text().splitlines():
        if line.startswith("#") or not line.strip():
            continue
        t, name = line.split()[:2]
        yield float(t), folder / name


def stamp(types, t):
    sec = int(t)
    return types["builtin_interfaces/msg/Time"](sec=sec, nanosec=int(round((t - sec) * 1e9)))


def qmul(a, b):
    """Hamilton product of (w, x, y, z) quaternions."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw])


def qrot(q, v):
    """v rotated by the unit quaternion q (w, x, y, z)."""
    w, x, y, z = q
    return qmul(qmul(q, np.array([0.0, *v])), np.array([w, -x, -y, -z]))[1:]


# base_link → camera: the optical axes (z ahead, x right, y down) on a base with x ahead, y
# left, z up, and the camera 0.1 m ahead of and 0.3 m above the base's origin.
BASE_CAMERA_Q = np.array([0.5, -0.5, 0.5, -0.5])
BASE_CAMERA_T = np.array([0.1, 0.0, 0.3])


def write_odometry(w, ts, folder):
    T = ts.types
    odom = w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=ts)
    tf = w.add_connection("/tf_static", "tf2_msgs/msg/TFMessage", typestore=ts)
    Header, Time = T["std_msgs/msg/Header"], T["builtin_interfaces/msg/Time"]
    static = T["geometry_msgs/msg/TransformStamped"](
        header=Header(stamp=Time(sec=0, nanosec=0), frame_id="base_link"), child_frame_id="camera",
        transform=T["geometry_msgs/msg/Transform"](
            translation=T["geometry_msgs/msg/Vector3"](x=BASE_CAMERA_T[0], y=BASE_CAMERA_T[1], z=BASE_CAMERA_T[2]),
            rotation=T["geometry_msgs/msg/Quaternion"](w=BASE_CAMERA_Q[0], x=BASE_CAMERA_Q[1], y=BASE_CAMERA_Q[2], z=BASE_CAMERA_Q[3])))
    w.write(tf, 1, ts.serialize_cdr(T["tf2_msgs/msg/TFMessage"](transforms=[static]), "tf2_msgs/msg/TFMessage"))
    inv_q = BASE_CAMERA_Q * np.array([1, -1, -1, -1])
    for line in (folder / "groundtruth.txt").read_text().splitlines():
        if line.startswith("#") or not line.strip():
            continue
        t, tx, ty, tz, qx, qy, qz, qw = (float(v) for v in line.split()[:8])
        q_cam = np.array([qw, qx, qy, qz])
        # T_odom_base = T_odom_camera · T_base_camera⁻¹
        q_base = qmul(q_cam, inv_q)
        p_base = np.array([tx, ty, tz]) - qrot(q_base, BASE_CAMERA_T)
        zero = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
        pose = T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=p_base[0], y=p_base[1], z=p_base[2]),
            orientation=T["geometry_msgs/msg/Quaternion"](w=q_base[0], x=q_base[1], y=q_base[2], z=q_base[3]))
        msg = T["nav_msgs/msg/Odometry"](
            header=Header(stamp=stamp(T, t), frame_id="odom"), child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](linear=zero, angular=zero), covariance=np.zeros(36)))
        w.write(odom, int(round(t * 1e9)) + 1_000_000_000, ts.serialize_cdr(msg, "nav_msgs/msg/Odometry"))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", type=pathlib.Path)
    ap.add_argument("out", type=pathlib.Path)
    ap.add_argument("--compressed", action="store_true", help="PNG CompressedImage frames")
    ap.add_argument("--mono", action="store_true", help="mono8 raw frames")
    ap.add_argument("--extra-image-topic", action="store_true", help="a second image topic")
    ap.add_argument("--odom", action="store_true",
                    help="groundtruth.txt as nav_msgs/Odometry of a base_link that /tf_static "
                         "places 0.1 m behind and 0.3 m below the camera, axes as REP 103")
    a = ap.parse_args()
    ts = get_typestore(Stores.ROS2_HUMBLE)
    Header = ts.types["std_msgs/msg/Header"]
    cam = tomllib.loads((a.folder / "calib.toml").read_text())["camera"]
    with Writer(a.out, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        kind = "sensor_msgs/msg/CompressedImage" if a.compressed else "sensor_msgs/msg/Image"
        image = w.add_connection("/camera/image", kind, typestore=ts)
        extra = w.add_connection("/camera2/image", kind, typestore=ts) if a.extra_image_topic else None
        info = w.add_connection("/camera/camera_info", "sensor_msgs/msg/CameraInfo", typestore=ts)
        Info = ts.types["sensor_msgs/msg/CameraInfo"]
        Roi = ts.types["sensor_msgs/msg/RegionOfInterest"]
        if a.odom:
            write_odometry(w, ts, a.folder)
        for i, (t, path) in enumerate(frames(a.folder)):
            ns = int(round(t * 1e9)) + 1_000_000_000
            header = Header(stamp=stamp(ts.types, t), frame_id="camera")
            if i == 0:
                k = np.array([cam["fx"], 0, cam["cx"], 0, cam["fy"], cam["cy"], 0, 0, 1], dtype=np.float64)
                d = np.array([cam.get(n, 0.0) for n in ("k1", "k2", "p1", "p2", "k3")], dtype=np.float64)
                p = np.array([cam["fx"], 0, cam["cx"], 0, 0, cam["fy"], cam["cy"], 0, 0, 0, 1, 0], dtype=np.float64)
                msg = Info(header=header, height=cam["height"], width=cam["width"],
                           distortion_model="plumb_bob", d=d, k=k, r=np.eye(3).ravel(), p=p,
                           binning_x=0, binning_y=0,
                           roi=Roi(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False))
                w.write(info, ns, ts.serialize_cdr(msg, "sensor_msgs/msg/CameraInfo"))
            if a.compressed:
                msg = ts.types[kind](header=header, format="png",
                                     data=np.frombuffer(path.read_bytes(), dtype=np.uint8))
            else:
                img = PilImage.open(path).convert("L" if a.mono else "RGB")
                arr = np.asarray(img, dtype=np.uint8)
                h, wd = arr.shape[:2]
                ch = 1 if a.mono else 3
                msg = ts.types[kind](header=header, height=h, width=wd,
                                     encoding="mono8" if a.mono else "rgb8", is_bigendian=0,
                                     step=wd * ch, data=arr.reshape(-1))
            data = ts.serialize_cdr(msg, kind)
            w.write(image, ns, data)
            if extra is not None:
                w.write(extra, ns, data)


if __name__ == "__main__":
    main()
