"""vdbmap.sim from Python: worlds answer distances and rays exactly, the depth camera renders the
analytic depth of a box room, drift presets are the paper's levels, configs start from C++'s
defaults, bad arrays raise ValueError, and a flight recorded from Python replays frame for frame."""
from __future__ import annotations

import re

import numpy as np
import pytest

import vdbmap
import vdbmap.sim as sim
from conftest import cli_path

ROOM_MIN = np.array([-3.0, -2.0, 0.0])
ROOM_MAX = np.array([3.0, 2.0, 2.5])
# The mesh holds float32 vertices; these corners are exact in float32, so depths and distances are
# exact up to the float32 depth image (and double arithmetic for distances).
DEPTH_TOLERANCE_M = 1e-5
DISTANCE_TOLERANCE_M = 1e-9
# Ray directions, like all (N, 3) arrays, pass through float32: a diagonal one is off by ~1e-8 rad.
RAY_TOLERANCE_M = 1e-6


def box_mesh(lo, hi):
    """The 12 triangles of the box [lo, hi] (faces seen from either side: the world needs no winding)."""
    corners = np.array([[hi[0] if k & 1 else lo[0], hi[1] if k & 2 else lo[1], hi[2] if k & 4 else lo[2]]
                        for k in range(8)], dtype=np.float32)
    quads = [(0, 2, 6, 4), (1, 5, 7, 3), (0, 4, 5, 1), (2, 3, 7, 6), (0, 1, 3, 2), (4, 6, 7, 5)]
    triangles = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))], dtype=np.int32)
    return corners, triangles


@pytest.fixture(scope="module")
def room():
    return sim.World(box_mesh(ROOM_MIN, ROOM_MAX))


def small_camera_config(width=64, height=48):
    """The default camera's field of view at a reduced resolution (fx scales with the width)."""
    config = sim.DepthCameraConfig()
    scale = width / config.intrinsics.width
    config.intrinsics = vdbmap.CameraIntrinsics(width=width, height=height, fx=config.intrinsics.fx * scale,
                                                fy=config.intrinsics.fy * scale, cx=width / 2.0, cy=height / 2.0)
    return config


def test_world_bounds_mesh_and_exact_distances(room):
    lo, hi = room.bounds
    np.testing.assert_array_equal(lo, ROOM_MIN)
    np.testing.assert_array_equal(hi, ROOM_MAX)
    vertices, triangles = room.mesh
    assert triangles.shape == (12, 3) and room.stats.triangles == 12 and room.stats.degenerate_dropped == 0

    # Inside a box room the nearest surface is the nearest of its six planes.
    rng = np.random.default_rng(5)
    # float32 points: the module holds points as float32, so the reference starts from the same values.
    points = rng.uniform(ROOM_MIN + 0.05, ROOM_MAX - 0.05, size=(200, 3)).astype(np.float32)
    expected = np.minimum(points - ROOM_MIN, ROOM_MAX - points).min(axis=1)  # in float64
    np.testing.assert_allclose(room.distance(points), expected, rtol=0, atol=DISTANCE_TOLERANCE_M)
    # A cap returns the cap where the surface is farther.
    np.testing.assert_allclose(room.distance(points, max_distance_m=0.3), np.minimum(expected, 0.3),
                               rtol=0, atol=DISTANCE_TOLERANCE_M)
    np.testing.assert_array_equal(room.is_clear(points, 0.5), expected >= 0.5)
    assert room.is_segment_clear([-2, 0, 1.2], [2, 0, 1.2], 0.5)
    assert not room.is_segment_clear([-2, 0, 1.2], [2, 0, 0.2], 0.5)  # ends 0.2 m above the floor


def test_raycasts_hit_the_walls_at_their_distance(room):
    origins = np.tile([0.0, 0.0, 1.2], (4, 1))
    directions = np.array([[1, 0, 0], [0, -2, 0], [0, 0, 1], [1, 1, 0]], dtype=np.float64)  # normalised by the call
    t, triangle = room.raycast(origins, directions)
    np.testing.assert_allclose(t, [3.0, 2.0, 1.3, 2.0 * np.sqrt(2.0)], rtol=0, atol=RAY_TOLERANCE_M)
    assert (triangle >= 0).all()
    t, triangle = room.raycast(origins, directions, max_t=1.5)
    assert np.isinf(t[[0, 1, 3]]).all() and (triangle[[0, 1, 3]] == -1).all() and t[2] == pytest.approx(1.3)


@pytest.mark.parametrize("yaw, wall_distance_m", [(0.0, 3.0), (np.pi / 2, 2.0), (np.pi, 3.0), (-np.pi / 2, 2.0)])
def test_rendering_a_box_room_gives_the_analytic_depth_at_the_image_centre(room, yaw, wall_distance_m):
    camera = sim.DepthCamera(small_camera_config())
    T_W_S = sim.looking_pose([0.0, 0.0, 1.2], yaw)
    depth = camera.render(room, T_W_S)
    K = camera.intrinsics
    assert depth.dtype == np.float32 and depth.shape == (K.height, K.width) == (48, 64)
    # The wall ahead is perpendicular to the optical axis: every pixel that sees it has its distance.
    centre = depth[K.height // 2 - 1:K.height // 2 + 1, K.width // 2 - 1:K.width // 2 + 1]
    np.testing.assert_allclose(centre, wall_distance_m, rtol=0, atol=DEPTH_TOLERANCE_M)
    # The reference renderer (one ray per pixel) gives the same image.
    np.testing.assert_allclose(camera.render_by_raycast(room, T_W_S), depth, rtol=0, atol=DEPTH_TOLERANCE_M)


def test_depth_beyond_the_range_is_invalid_and_noise_is_seeded(room):
    config = small_camera_config()
    config.max_range_m = config.far_clip_m = 2.5
    depth = sim.DepthCamera(config).render(room, sim.looking_pose([0.0, 0.0, 1.2], 0.0))
    assert depth[24, 32] == 0.0  # the wall 3 m ahead is out of range

    config = small_camera_config()
    config.noise_sigma_m = 0.01
    camera = sim.DepthCamera(config)
    T = sim.looking_pose([0.0, 0.0, 1.2], 0.0)
    np.testing.assert_array_equal(camera.render(room, T, frame=3), camera.render(room, T, frame=3))
    assert not np.array_equal(camera.render(room, T, frame=3), camera.render(room, T, frame=4))


def test_drift_presets_are_table_one():
    s3 = sim.DriftConfig.preset("s3", seed=7)
    assert (s3.mu_xyz_mps, s3.sigma2_xyz_m2ps2, s3.mu_yaw_radps, s3.sigma2_yaw_rad2ps2) == (0.0, 5e-2, 1e-3, 5e-2)
    assert s3.seed == 7 and not s3.is_zero() and sim.DriftConfig.preset("s1").is_zero()
    with pytest.raises(ValueError, match="s5"):
        sim.DriftConfig.preset("s5")


def cli_default(command, option):
    """The default `vdbmap <command> --help` shows for an option (CLI11 prints `--option TYPE=default`)."""
    import subprocess
    path = cli_path()
    if not path.exists():
        pytest.skip(f"the vdbmap CLI is not at {path}")
    text = subprocess.run([str(path), command, "--help"], capture_output=True, text=True, check=True).stdout
    match = re.search(rf"^\s*{re.escape(option)} [^\n]*?=(\S+)", text, re.MULTILINE)
    assert match, f"no default for {option} in `vdbmap {command} --help`:\n{text}"
    return match.group(1)


def test_configs_start_from_the_cpp_defaults():
    camera = sim.DepthCameraConfig()
    K = camera.intrinsics
    assert (K.width, K.height, K.fx, K.fy, K.cx, K.cy) == (640, 480, 387.229, 387.229, 320.0, 240.0)
    assert (camera.rate_hz, camera.min_range_m, camera.max_range_m, camera.far_clip_m) == (15.0, 0.1, 5.0, 5.0)
    config = sim.SimulatorConfig()
    assert config.drift.is_zero() and str(config.loop_closure) == "pgo"
    assert (sim.MotionLimits().v_max_mps, sim.MotionLimits().a_max_mps2, sim.MotionLimits().yaw_rate_max_radps) == \
        (2.0, 2.0, 0.9)
    assert sim.WorldConfig().ceiling_clip_z_m == float("inf") and not sim.WorldConfig().cap_ceiling
    # The same defaults the CLI shows (both come from the C++ structs).
    assert cli_default("simulate", "--loop-closure") == str(config.loop_closure)
    assert cli_default("simulate", "--drift") == "s1"


def test_configs_edit_in_place_and_reject_bad_values():
    config = sim.SimulatorConfig(loop_closure="perfect", camera_pitch_rad=0.1)
    assert config.loop_closure == sim.LoopClosureMode.Perfect
    config.camera.intrinsics.width = 80
    config.drift.seed = 9
    assert config.camera.intrinsics.width == 80 and config.drift.seed == 9
    with pytest.raises(ValueError, match="loop closure|pgo"):
        config.loop_closure = "sometimes"
    config.camera.rate_hz = -1.0
    with pytest.raises(ValueError, match="rate_hz"):
        config.validate()
    with pytest.raises(ValueError, match="rate_hz"):
        sim.DepthCamera(config.camera)
    with pytest.raises(TypeError, match="nonsense"):
        sim.SimulatorConfig(nonsense=1)


def test_bad_arrays_raise_value_errors_naming_the_argument(room, tmp_path):
    with pytest.raises(ValueError, match=r"points: expected an \(N, 3\)"):
        room.distance(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="points"):
        room.is_clear(np.zeros(3), 0.1)
    with pytest.raises(ValueError, match="directions_W: expected as many rows"):
        room.raycast(np.zeros((2, 3)), np.ones((3, 3)))
    with pytest.raises(ValueError, match=r"T_W_S: expected a \(4, 4\)"):
        sim.DepthCamera(small_camera_config()).render(room, np.eye(3))
    with pytest.raises(ValueError, match="position_W"):
        sim.looking_pose([0.0, 1.0], 0.0)
    vertices, triangles = box_mesh(ROOM_MIN, ROOM_MAX)
    with pytest.raises(ValueError, match="refers to vertex 8"):
        sim.World((vertices, np.array([[0, 1, 8]])))
    with pytest.raises(ValueError, match=r"waypoints: expected an \(N, 4\)"):
        sim.simulate_flight(room, tmp_path / "log", waypoints=np.zeros((3, 3)))
    with pytest.raises(OSError):
        sim.World.load(tmp_path / "missing.ply")


def test_a_flight_written_from_python_replays_with_the_same_frame_count(room, tmp_path):
    config = sim.SimulatorConfig()
    config.camera = small_camera_config(80, 60)
    config.drift = sim.DriftConfig.preset("s2", seed=4)
    waypoints = np.array([[-2.0, 0.0, 1.2, 0.0], [2.0, 0.0, 1.2, 0.0], [2.0, 1.0, 1.2, np.pi / 2]])
    calls = []
    flight = sim.simulate_flight(room, tmp_path / "log", config, waypoints,
                                 progress=lambda done, total: calls.append((done, total)))
    # Frames every camera period from the start to the end of the flight.
    assert flight.frames == int(np.floor(flight.duration_s * config.camera.rate_hz + 1e-9)) + 1
    assert flight.path_length_m == pytest.approx(5.0, abs=1e-6)
    assert calls[-1] == (flight.frames, flight.frames)
    assert flight.odometry_error_final_m > 0.0  # s2 drifts

    source = vdbmap.open_dataset(tmp_path / "log")
    assert len(source) == flight.frames and source.sensor.intrinsics.width == 80
    mapper_config = vdbmap.MapperConfig(mode="keyframes")
    mapper_config.tsdf.voxel_size_m = 0.1
    result = vdbmap.replay_log(source, vdbmap.Mapper(mapper_config))
    assert result.frames_integrated == flight.frames

    with pytest.raises(OSError, match="already holds a log"):
        sim.simulate_flight(room, tmp_path / "log", config, waypoints)
    again = sim.simulate_flight(room, tmp_path / "log", config, waypoints, overwrite=True)
    assert again.frames == flight.frames and again.odometry_error_final_m == flight.odometry_error_final_m
