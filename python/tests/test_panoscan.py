"""The Python module on small simulated scans: reading scans and panoramas into numpy, simulating,
tracking, building a panorama, registering, evaluating clouds and trajectories, errors as
panoscan.Error, and the GIL released around long calls."""

import math
import os
import threading
import time

import numpy as np
import pytest

import panoscan


@pytest.fixture(scope="module")
def small_scan(tmp_path_factory):
    """Office SO-1 at 64x48, every 120th frame: three cameras, a few frames each."""
    out = tmp_path_factory.mktemp("scan") / "so1"
    path = panoscan.simulate("office", "SO-1", out=str(out), resolution="64x48", every=120, seed=3, threads=2)
    assert path == str(out)
    return out


@pytest.fixture(scope="module")
def panorama(small_scan, tmp_path_factory):
    out = tmp_path_factory.mktemp("pano") / "p1"
    pano = panoscan.build_panorama(str(small_scan), poses="ground-truth", height=64, out=str(out), threads=2)
    return out, pano


def panorama_points(pano):
    """The panorama's points in the world frame, from its radial depth (panorama convention: z up,
    column u at azimuth 2 pi (u + 0.5) / W from +x towards +y, row v at polar angle pi (v + 0.5) / H)."""
    depth = pano["depth"]
    h, w = depth.shape
    v, u = np.nonzero(depth > 0)
    phi = 2 * math.pi * (u + 0.5) / w
    theta = math.pi * (v + 0.5) / h
    r = depth[v, u]
    local = np.stack([r * np.sin(theta) * np.cos(phi), r * np.sin(theta) * np.sin(phi), r * np.cos(theta)], axis=1)
    m = pano["world_from_pano"]
    return local @ m[:3, :3].T + m[:3, 3]


def test_version():
    assert panoscan.__version__
    assert panoscan.source_revision


def test_read_scan_gives_frames_as_numpy(small_scan):
    scan = panoscan.read_scan(str(small_scan))
    assert scan.sensors == ["cam0", "cam1", "cam2"]
    assert scan.rig["reference_sensor"] == 1
    assert scan.rig["motion"] == "rotator"
    assert scan.rig["sensors"][0]["width"] == 64
    assert scan.rig["sensors"][1]["ref_from_cam"].shape == (4, 4)
    np.testing.assert_allclose(scan.rig["sensors"][1]["ref_from_cam"], np.eye(4))
    frames = scan.frames
    assert len(frames) == 3 and all(len(f) >= 3 for f in frames)
    times = [f.timestamp for f in frames[1]]
    assert times == sorted(times)
    frame = frames[1][0]
    assert os.path.exists(frame.rgb_path) and os.path.exists(frame.depth_path)
    rgb, depth = frame.rgb, frame.depth
    assert rgb.shape == (48, 64, 3) and rgb.dtype == np.uint8
    assert depth.shape == (48, 64) and depth.dtype == np.float32
    valid = depth[depth > 0]
    assert valid.size > depth.size / 2 and 0.3 < np.median(valid) < 8.0  # metres, an office


def test_panorama_to_numpy_and_back(panorama):
    out, pano = panorama
    assert pano["colour"].shape == (64, 128, 3) and pano["colour"].dtype == np.float32
    for key in ("depth", "variance", "count"):
        assert pano[key].shape == (64, 128)
    assert pano["world_from_pano"].shape == (4, 4)
    again = panoscan.read_panorama(str(out))
    np.testing.assert_array_equal(again["depth"], pano["depth"])
    np.testing.assert_array_equal(again["colour"], pano["colour"])
    np.testing.assert_allclose(again["world_from_pano"], pano["world_from_pano"], atol=1e-9)
    assert (pano["count"][pano["depth"] > 0] >= 1).all()


def test_eval_cloud_on_arrays_and_files(small_scan, panorama):
    out, pano = panorama
    mesh = str(small_scan / "groundtruth" / "mesh.ply")
    points = panorama_points(pano)
    from_array = panoscan.eval_cloud(points, mesh, threads=2)
    assert from_array["accuracy"]["count"] == len(points)
    assert from_array["rmse_mm"] < 40.0  # a 64-row panorama of a noisy 64x48 scan
    # The panorama's own cloud.ply holds the same points: the same figures through the file path.
    from_file = panoscan.eval_cloud(str(out / "cloud.ply"), mesh, threads=2)
    assert from_file["rmse_mm"] == pytest.approx(from_array["rmse_mm"], rel=1e-3)
    shifted = panoscan.eval_cloud(points + np.array([0.0, 0.0, 0.1]), mesh, threads=2)
    assert shifted["rmse_mm"] > from_array["rmse_mm"] + 30.0


def rotation_z(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def test_register_point_arrays_recovers_a_known_transform(panorama):
    _, pano = panorama
    source = panorama_points(pano)
    truth = np.eye(4)
    truth[:3, :3] = rotation_z(math.radians(1.5))
    truth[:3, 3] = [0.03, -0.02, 0.01]
    target = source @ truth[:3, :3].T + truth[:3, 3]
    result = panoscan.register(source, target, method="gicp", threads=2)
    estimate = result["target_from_source"]
    assert np.linalg.norm(estimate[:3, 3] - truth[:3, 3]) < 1e-3
    angle = math.degrees(math.acos(min(1.0, (np.trace(estimate[:3, :3].T @ truth[:3, :3]) - 1) / 2)))
    assert angle < 0.05
    assert result["converged"]


def test_register_panorama_folders_with_an_initial_pose(panorama):
    out, _ = panorama
    result = panoscan.register(str(out), str(out), initial=np.eye(4), threads=2)
    assert np.linalg.norm(result["target_from_source"][:3, 3]) < 0.01
    with pytest.raises(panoscan.Error, match="4x4"):
        panoscan.register(str(out), str(out), initial=np.eye(3))


def test_eval_traj_on_arrays_and_files(small_scan):
    gt_path = str(small_scan / "groundtruth" / "cam1.txt")
    gt = np.loadtxt(gt_path)
    same = panoscan.eval_traj(gt_path, gt, rpe_delta_s=8.0)  # every 120th frame: 4 s apart
    assert same["ate_rmse_mm"] < 1e-6
    rng = np.random.default_rng(1)
    noisy = gt.copy()
    noisy[:, 1:4] += rng.normal(0.0, 0.005, size=(len(gt), 3))
    figures = panoscan.eval_traj(gt, noisy, rpe_delta_s=8.0)
    assert 2.0 < figures["ate_rmse_mm"] < 12.0
    assert figures["matched_poses"] == len(gt)


def test_track_returns_trajectories_and_the_verdict(tmp_path):
    scan = panoscan.simulate("office", "SO-1", out=str(tmp_path / "scan"), resolution="320x240", every=32, seed=2,
                             threads=2)
    result = panoscan.track(scan, mode="full", threads=2, out=str(tmp_path / "track"))
    assert result["reliable"]
    assert result["verdict"]["reliable"]
    trajectory = result["trajectories"]["cam1"]
    assert trajectory.shape[1] == 8
    assert os.path.exists(tmp_path / "track" / "cam1.txt")
    ate = panoscan.eval_traj(os.path.join(scan, "groundtruth", "cam1.txt"), trajectory)
    assert ate["ate_rmse_mm"] < 20.0


def test_errors_are_panoscan_errors_with_the_programs_message(tmp_path, small_scan):
    with pytest.raises(panoscan.Error, match="no-such-scan"):
        panoscan.read_scan(str(tmp_path / "no-such-scan"))
    with pytest.raises(panoscan.Error, match="noise.preset"):
        panoscan.simulate("office", out=str(tmp_path / "bad"), config={"noise.preset": "loud"})
    with pytest.raises(panoscan.Error, match="noise.prest"):
        panoscan.simulate("office", out=str(tmp_path / "bad"), config={"noise.prest": "kinect"})
    # A 64x48 scan, four frames per camera, is too small to track: refused as the program refuses it (exit 2).
    with pytest.raises(panoscan.Error, match="no verified frame pair"):
        panoscan.track(str(small_scan), threads=2)
    assert issubclass(panoscan.Error, RuntimeError)


def test_long_calls_release_the_gil(tmp_path):
    """While simulate() runs in a thread, Python code keeps running in this one."""
    done = threading.Event()

    def work():
        panoscan.simulate("office", out=str(tmp_path / "gil"), resolution="160x120", every=8, threads=1)
        done.set()

    worker = threading.Thread(target=work)
    start = time.perf_counter()
    worker.start()
    ticks = 0
    while not done.is_set() and time.perf_counter() - start < 120:
        ticks += 1
        time.sleep(0.001)
    worker.join()
    elapsed = time.perf_counter() - start
    assert done.is_set()
    assert elapsed > 0.2  # long enough to measure
    # With the GIL held the loop would stall for the whole call; released, it ticks throughout.
    assert ticks > 0.3 * elapsed / 0.0015
