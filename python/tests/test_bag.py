"""ROS 2 bags (issue 23): `steernav slam BAG` against bags written by the independent `rosbags`
writer (tools/make_bag.py) from a generated sequence, compared with the same frames in a
folder; and the bad-bag errors."""

import json
import math
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def run(*args, ok=True):
    p = subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=600)
    if ok:
        assert p.returncode == 0, p.stderr
    return p


@pytest.fixture(scope="module")
def sequence(cli_exe, tmp_path_factory):
    out = tmp_path_factory.mktemp("synth") / "seq"
    run(cli_exe, "slam-synth", "--frames", "60", "--out", out)
    return out


def make_bag(sequence, out, *flags):
    run(sys.executable, ROOT / "tools" / "make_bag.py", sequence, out, *flags)
    return out


@pytest.fixture(scope="module")
def folder_trajectory(cli_exe, sequence, tmp_path_factory):
    out = tmp_path_factory.mktemp("slam-folder")
    run(cli_exe, "slam", sequence, "--out", out, "--backend", "cpu")
    return (out / "trajectory.txt").read_text()


@pytest.mark.parametrize("flags", [(), ("--compressed",)], ids=["rgb8", "png"])
def test_slam_on_a_bag_follows_the_folder_run(cli_exe, sequence, folder_trajectory, tmp_path, flags):
    bag = make_bag(sequence, tmp_path / "bag", *flags)
    out = tmp_path / "out"
    p = run(cli_exe, "slam", bag, "--out", out, "--backend", "cpu")
    assert "60 frames (ROS 2 bag layout)" in p.stdout
    # Same frames, same CameraInfo-derived camera, same header stamps: the same trajectory.
    assert (out / "trajectory.txt").read_text() == folder_trajectory
    # A single .mcap file is a bag too.
    (mcap,) = bag.glob("*.mcap")
    run(cli_exe, "slam", mcap, "--out", tmp_path / "out2", "--backend", "cpu")
    assert (tmp_path / "out2" / "trajectory.txt").read_text() == folder_trajectory


def test_mono8_frames_track(cli_exe, sequence, tmp_path):
    bag = make_bag(sequence, tmp_path / "bag", "--mono")
    p = run(cli_exe, "slam", bag, "--out", tmp_path / "out", "--backend", "cpu")
    assert "tracking lost on 0 frames" in p.stdout
    rows = [l for l in (tmp_path / "out" / "trajectory.txt").read_text().splitlines() if not l.startswith("#")]
    assert len(rows) == 60


def test_bad_bags_are_refused_by_name(cli_exe, sequence, tmp_path):
    two = make_bag(sequence, tmp_path / "two", "--extra-image-topic")
    p = run(cli_exe, "slam", two, "--out", tmp_path / "x", ok=False)
    assert p.returncode != 0 and "choose one with --image-topic" in p.stderr
    assert "/camera/image, /camera2/image" in p.stderr
    p = run(cli_exe, "slam", two, "--out", tmp_path / "x", "--image-topic", "/nope", ok=False)
    assert p.returncode != 0 and "has no topic /nope" in p.stderr and "sensor_msgs/msg/CameraInfo" in p.stderr
    not_mcap = tmp_path / "not.mcap"
    not_mcap.write_text("hello")
    p = run(cli_exe, "slam", not_mcap, "--out", tmp_path / "x", ok=False)
    assert p.returncode != 0 and "not.mcap: not an MCAP file" in p.stderr


def test_a_truncated_bag_keeps_what_was_read(cli_exe, sequence, tmp_path):
    bag = make_bag(sequence, tmp_path / "bag")
    (mcap,) = bag.glob("*.mcap")
    data = mcap.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    out = tmp_path / "out"
    p = run(cli_exe, "slam", cut, "--out", out, "--backend", "cpu", ok=False)
    assert p.returncode != 0, p.stdout
    assert "cut.mcap" in p.stderr and "stopped after" in p.stderr, p.stderr
    rows = [l for l in (out / "trajectory.txt").read_text().splitlines() if not l.startswith("#")]
    assert 10 < len(rows) < 60


def corridor_log(path):
    """FLASER lines of a robot at (0.1 k, 0.02 k^1.5) heading along its path between walls."""
    lines = ["# generated"]
    n = 181
    for k in range(120):
        x, t = 0.1 * k, 100.0 + 0.1 * k
        ranges = []
        for i in range(n):
            b = -math.pi / 2 + i * math.pi / (n - 1)
            ranges.append(30.0 if abs(math.sin(b)) < 1e-6 else min(1.0 / abs(math.sin(b)), 30.0))
        th = 0.05 * math.sin(0.1 * k)
        lines.append("FLASER %d %s %.6f 0 %.6f %.6f 0 %.6f %.6f test %.6f"
                     % (n, " ".join("%.3f" % r for r in ranges), x, th, x, th, t, t))
    path.write_text("\n".join(lines) + "\n")
    return path


def test_nav_replay_on_a_bag_matches_the_carmen_log(cli_exe, tmp_path):
    log = corridor_log(tmp_path / "corridor.log")
    bag = tmp_path / "corridor_bag"
    run(sys.executable, ROOT / "tools" / "carmen_to_bag.py", log, bag)
    carmen = json.loads(run(cli_exe, "nav-replay", log, "--json").stdout)
    ros = json.loads(run(cli_exe, "nav-replay", bag, "--json").stdout)
    assert carmen["scans"] > 100 and ros["scans"] == carmen["scans"]
    assert ros["free_fraction"] == carmen["free_fraction"]
    # The bag carries the bearings and ranges as float32, the log as decimals read into f32.
    assert abs(ros["mean_abs_deviation_deg"] - carmen["mean_abs_deviation_deg"]) < 1e-6
    p = run(cli_exe, "nav-replay", bag, "--scan-topic", "/odom", ok=False)
    assert p.returncode != 0 and "carries nav_msgs/msg/Odometry, not sensor_msgs/msg/LaserScan" in p.stderr
    p = run(cli_exe, "nav-replay", log, "--scan-topic", "/scan", ok=False)
    assert p.returncode != 0 and "apply to ROS 2 bags only" in p.stderr


def recompress(src, dst, compression):
    """Rewrites an MCAP file with chunks compressed by `compression`, with the `mcap` library's
    own reader and writer (an implementation independent of rosbags and of steernav's)."""
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    with open(src, "rb") as f, open(dst, "wb") as out:
        reader = make_reader(f)
        writer = Writer(out, compression=CompressionType[compression], chunk_size=256 * 1024)
        writer.start(profile="ros2", library="test")
        schemas, channels = {}, {}
        for schema, channel, message in reader.iter_messages():
            if schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(schema.name, schema.encoding, schema.data)
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id])
            writer.add_message(channels[channel.id], message.log_time, message.data,
                               message.publish_time)
        writer.finish()


@pytest.mark.parametrize("compression", ["ZSTD", "LZ4"])
def test_compressed_chunks(cli_exe, sequence, folder_trajectory, tmp_path, compression):
    bag = make_bag(sequence, tmp_path / "bag")
    (mcap,) = bag.glob("*.mcap")
    packed = tmp_path / f"packed_{compression}.mcap"
    recompress(mcap, packed, compression)
    assert packed.stat().st_size < mcap.stat().st_size
    run(cli_exe, "slam", packed, "--out", tmp_path / "out", "--backend", "cpu")
    assert (tmp_path / "out" / "trajectory.txt").read_text() == folder_trajectory


def decoded(path):
    """(topic, schema name, log time, message) of every message, decoded by mcap-ros2-support."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [(c.topic, s.name, m.log_time, d) for s, c, m, d in reader.iter_decoded_messages()]


def test_slam_results_as_mcap(cli_exe, sequence, tmp_path):
    bag = make_bag(sequence, tmp_path / "bag")
    out = tmp_path / "out"
    run(cli_exe, "slam", bag, "--out", out, "--mcap", tmp_path / "slam.mcap", "--backend", "cpu")
    rows = [l.split() for l in (out / "trajectory.txt").read_text().splitlines() if not l.startswith("#")]
    msgs = decoded(tmp_path / "slam.mcap")
    poses = [m for m in msgs if m[0] == "/steernav/pose"]
    assert len(poses) == len(rows) == 60
    assert {m[1] for m in poses} == {"geometry_msgs/msg/PoseStamped"}
    same = lambda p, row: [round(v, 6) for v in (p.position.x, p.orientation.x, p.orientation.w)] == [
        round(float(row[1]), 6), round(float(row[4]), 6), round(float(row[7]), 6)]
    for k, ((_, _, log_time, p), row) in enumerate(zip(poses, rows)):
        t = float(row[0])
        assert abs(p.header.stamp.sec + p.header.stamp.nanosec * 1e-9 - t) < 1e-9
        assert abs(log_time * 1e-9 - t) < 1e-6 and p.header.frame_id == "map"
        # The stream sends each pose as reported; trajectory.txt takes the start's revisions
        # (its wait, and a 30-frame trial), so the two agree once those are over.
        if k >= 40:
            assert same(p.pose, row), k
    (path,) = [m for m in msgs if m[0] == "/steernav/path"]
    assert path[1] == "nav_msgs/msg/Path" and len(path[3].poses) == 60
    # The final path is the revised trajectory, every frame.
    assert all(same(p.pose, row) for p, row in zip(path[3].poses, rows))
    (cloud,) = [m for m in msgs if m[0] == "/steernav/landmarks"]
    assert cloud[1] == "sensor_msgs/msg/PointCloud2"
    assert [f.name for f in cloud[3].fields] == ["x", "y", "z"]
    assert cloud[3].width > 10 and len(cloud[3].data) == 12 * cloud[3].width


def test_nav_replay_commands_as_mcap(cli_exe, tmp_path):
    log = corridor_log(tmp_path / "corridor.log")
    result = json.loads(run(cli_exe, "nav-replay", log, "--json", "--mcap", tmp_path / "nav.mcap").stdout)
    msgs = decoded(tmp_path / "nav.mcap")
    twists = [m for m in msgs if m[0] == "/steernav/cmd_vel"]
    headings = [m for m in msgs if m[0] == "/steernav/heading"]
    assert len(twists) == len(headings) == result["scans"]
    assert {m[1] for m in twists} == {"geometry_msgs/msg/Twist"}
    assert {m[1] for m in headings} == {"std_msgs/msg/Float64"}
    # Stamped with the scans' times (100 s + 0.1 s per scan), in order.
    times = [m[2] * 1e-9 for m in twists]
    assert times == sorted(times) and abs(times[0] - 100.0) < 1e-6
    assert all(t.angular.x == 0 and t.linear.x > 0 for _, _, _, t in twists)
    # The corridor runs straight ahead: the chosen headings stay near 0.
    assert max(abs(h.data) for _, _, _, h in headings) < 0.5


def test_detect_on_a_bag_names_records_by_topic_and_stamp(cli_exe, sequence, tmp_path):
    bag = make_bag(sequence, tmp_path / "bag", "--compressed")
    out = tmp_path / "out"
    run(cli_exe, "detect", bag, "--out", out, "--mcap", tmp_path / "kp.mcap", "--backend", "cpu")
    records = sorted(out.glob("*.json"))
    assert len(records) == 60 and records[1].name == "camera_image_0.033333000.json"
    first = json.loads(records[0].read_text())
    assert first["image"].endswith(":/camera/image@0.000000000") and first["width"] == 320
    # The same keypoints as detect on the frame's own file.
    own = json.loads(run(cli_exe, "detect", sequence / "rgb" / "000000.png", "--backend", "cpu").stdout)
    assert first["keypoints"] == own["keypoints"]
    msgs = decoded(tmp_path / "kp.mcap")
    assert len(msgs) == 60 and {m[1] for m in msgs} == {"foxglove_msgs/msg/ImageAnnotations"}
    topic, _, log_time, ann = msgs[1]
    assert topic == "/steernav/keypoints" and log_time == 33_333_000
    assert ann.circles[0].timestamp.nanosec == 33_333_000
    rec = json.loads(records[1].read_text())
    assert len(ann.points[0].points) == len(ann.circles) == len(rec["keypoints"])
    assert abs(ann.points[0].points[0].x - rec["keypoints"][0]["x"]) < 1e-4
    p = run(cli_exe, "detect", bag, sequence / "rgb" / "000000.png", ok=False)
    assert p.returncode != 0 and "only input" in p.stderr


def test_batch_on_a_bag_resumes(cli_exe, sequence, tmp_path):
    bag = make_bag(sequence, tmp_path / "bag")
    out = tmp_path / "out"
    p = run(cli_exe, "batch", bag, "--out", out, "--backend", "cpu")
    assert "60 images detected, 0 skipped" in p.stderr
    rows = (out / "summary.csv").read_text().splitlines()
    assert len(rows) == 61 and rows[1].split(",")[1] == "done"
    (out / "camera_image_0.033333000.json").unlink()
    p = run(cli_exe, "batch", bag, "--out", out, "--backend", "cpu")
    assert "1 images detected, 59 skipped" in p.stderr
    assert len(list(out.glob("*.json"))) == 60


def test_python_reads_a_bag_frame_by_frame(cli_exe, sequence, folder_trajectory, tmp_path):
    import numpy as np
    import steernav

    bag = make_bag(sequence, tmp_path / "bag", "--compressed")
    reader = steernav.BagReader(bag)
    assert ("/camera/camera_info", "sensor_msgs/msg/CameraInfo") in reader.topics
    assert reader.image_topic == "/camera/image"
    camera = reader.camera()
    assert camera["width"] == 320 and camera["distortion"][0] == -0.05
    slam = steernav.Slam(**camera, backend="cpu")
    stamps = []
    for t, image in reader:
        assert image.shape == (240, 320, 3) and image.dtype == np.uint8
        slam.process(image, t)
        stamps.append(t)
    assert len(stamps) == 60 and stamps == sorted(stamps)
    # The same frames and camera as the CLI's folder run: the same last pose.
    last = [float(v) for v in folder_trajectory.strip().splitlines()[-1].split()]
    assert np.allclose(slam.trajectory()[-1], last, atol=1e-8)
    with pytest.raises(ValueError, match="choose one with --image-topic"):
        steernav.BagReader(make_bag(sequence, tmp_path / "two", "--extra-image-topic"))


def test_wheel_odometry_from_a_bag_through_tf_static(cli_exe, sequence, tmp_path):
    """The bag's odometry is of a base_link that /tf_static places away from the camera; put
    on the camera, it must drive SLAM as the camera's own trajectory does from a file."""
    bag = make_bag(sequence, tmp_path / "bag", "--odom")
    gt = sequence / "groundtruth.txt"
    ros = run(cli_exe, "slam", bag, "--odom-topic", "/odom", "--ground-truth", gt,
              "--out", tmp_path / "ros", "--backend", "cpu")
    tum = run(cli_exe, "slam", sequence, "--odometry", gt, "--out", tmp_path / "tum", "--backend", "cpu")
    rows = lambda d: [[float(v) for v in l.split()] for l in (d / "trajectory.txt").read_text().splitlines()
                      if not l.startswith("#")]
    a, b = rows(tmp_path / "ros"), rows(tmp_path / "tum")
    assert len(a) == len(b) > 50
    # Equal up to the rounding of the transforms (which the filter then carries along).
    assert max(abs(x - y) for ra, rb in zip(a[:40], b[:40]) for x, y in zip(ra, rb)) < 1e-6
    ate = lambda text: float(text.split("ATE ")[1].split(" m")[0])
    assert abs(ate(ros.stdout) - ate(tum.stdout)) < 0.002
    p = run(cli_exe, "slam", sequence, "--odom-topic", "/odom", "--out", tmp_path / "x", ok=False)
    assert p.returncode != 0 and "applies to ROS 2 bags only" in p.stderr
