"""numpy <-> C++ conversions: accepted layouts give identical results, values survive round trips
through the bindings and through files, and wrong shapes or dtypes raise ValueErrors that name the
argument, the expected and the received shape and dtype."""
from __future__ import annotations

import numpy as np
import pytest

import vdbmap
from conftest import png_units, pose, small_camera, wall_depth, wall_points


def wall_volume(points: np.ndarray) -> vdbmap.TsdfVolume:
    volume = vdbmap.TsdfVolume(vdbmap.TsdfConfig(voxel_size_m=0.05))
    volume.integrate(0, points, pose(yaw_deg=10.0))
    return volume


def test_points_in_any_float_layout_give_the_same_map():
    points = wall_points()
    reference = wall_volume(points)
    wider = np.zeros((len(points), 5), dtype=np.float64)
    wider[:, 1:4] = points
    layouts = {
        "float64": points.astype(np.float64),
        "fortran": np.asfortranarray(points),
        "strided slice of a wider array": wider[:, 1:4],
        "reversed twice": points[::-1][::-1],
        "nested lists": points.tolist(),
    }
    for name, layout in layouts.items():
        assert wall_volume(layout).exactly_equals(reference), name


def test_back_project_matches_the_pinhole_model_and_marks_invalid_pixels():
    depth = wall_depth(2.0)
    depth[3, 5] = 0.0
    depth[7, 9] = np.nan
    K = small_camera()
    points = vdbmap.back_project(depth, K)
    assert points.shape == (48 * 64, 3) and points.dtype == np.float32
    v, u = np.mgrid[0:48, 0:64]
    expected = np.stack([(u - K.cx) * depth / K.fx, (v - K.cy) * depth / K.fy, depth], axis=-1).reshape(-1, 3)
    valid = np.isfinite(depth.reshape(-1)) & (depth.reshape(-1) > 0)
    np.testing.assert_allclose(points[valid], expected[valid], rtol=1e-6, atol=1e-7)
    assert np.isnan(points[~valid]).all() and (~valid).sum() == 2
    assert vdbmap.back_project(depth, K, stride=4).shape == (12 * 16, 3)


def test_uint16_depth_with_a_scale_equals_the_float_conversion_bit_for_bit():
    rng = np.random.default_rng(3)
    raw = rng.integers(0, 4000, size=(48, 64), dtype=np.uint16)
    raw[0, :5] = 0
    scale = 0.001
    metres = raw.astype(np.float32) * np.float32(scale)  # what the C++ PNG reader computes
    a = vdbmap.back_project(raw, small_camera(), depth_scale=scale)
    b = vdbmap.back_project(metres, small_camera())
    np.testing.assert_array_equal(a, b)  # NaNs compare equal here
    volume_a = vdbmap.TsdfVolume()
    volume_a.integrate_depth(0, raw, small_camera(), pose(), depth_scale=scale)
    volume_b = vdbmap.TsdfVolume()
    volume_b.integrate_depth(0, metres, small_camera(), pose())
    assert volume_a.exactly_equals(volume_b)


def test_poses_round_trip_exactly_and_quaternions_follow_tum_order():
    volume = vdbmap.TsdfVolume()
    T = pose(0.3, -0.2, 0.1, yaw_deg=33.0)
    volume.integrate(7, wall_points(), T)
    poses = volume.integrated_poses()
    assert list(poses) == [7]
    assert poses[7].dtype == np.float64 and poses[7].shape == (4, 4)
    np.testing.assert_array_equal(poses[7], T)
    R = vdbmap.pose_from_translation_quaternion([1.0, 2.0, 3.0], 0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4))
    np.testing.assert_allclose(R, [[0, -1, 0, 1], [1, 0, 0, 2], [0, 0, 1, 3], [0, 0, 0, 1]], atol=1e-15)
    assert vdbmap.is_valid_rigid_transform(R)
    assert not vdbmap.is_valid_rigid_transform(np.diag([2.0, 1.0, 1.0, 1.0]))


def test_queries_return_arrays_aligned_with_the_points():
    volume = wall_volume(wall_points())
    # Along the optical axis (rotated 10 degrees about y): free, the wall's voxel, unknown behind.
    axis = pose(yaw_deg=10.0)[:3, 2]
    # 2.01 m: the voxel nearest to it is within 0.03 m of the wall, below the occupancy threshold.
    points = np.stack([axis * 1.0, axis * 2.01, axis * 3.0])
    tsdf, weight, state = volume.sample(points)
    assert tsdf.shape == weight.shape == state.shape == (3,)
    assert tsdf.dtype == np.float32 and weight.dtype == np.float32 and state.dtype == np.uint8
    assert list(state) == [int(vdbmap.VoxelState.Free), int(vdbmap.VoxelState.Occupied), int(vdbmap.VoxelState.Unknown)]
    assert weight[2] == 0.0 and tsdf[2] == pytest.approx(volume.config.truncation_m())
    ijk = volume.world_to_voxel(points)
    assert ijk.dtype == np.int32 and ijk.shape == (3, 3)
    np.testing.assert_array_equal(volume.sample_voxels(ijk)[0], tsdf)
    centres = volume.voxel_center(ijk)
    np.testing.assert_array_equal(volume.world_to_voxel(centres), ijk)
    assert np.abs(centres - points).max() <= 0.5 * 0.05 + 1e-12


def test_hit_counts_are_the_end_points_per_voxel_and_vanish_on_deintegration():
    points = wall_points()
    T = pose(yaw_deg=10.0)
    volume = wall_volume(points)
    ends_W = points @ T[:3, :3].T + T[:3, 3]
    ijk, counts = np.unique(volume.world_to_voxel(ends_W), axis=0, return_counts=True)
    hits = volume.hit_counts(volume.voxel_center(ijk))
    assert hits.dtype == np.int64 and hits.shape == (len(ijk),)
    np.testing.assert_array_equal(hits, counts)
    assert volume.hit_counts(np.zeros((1, 3)))[0] == 0  # the camera's own voxel: no surface there
    volume.deintegrate(0, points, T)
    assert (volume.hit_counts(volume.voxel_center(ijk)) == 0).all()


def test_known_voxels_are_the_saved_grids_values():
    volume = wall_volume(wall_points())
    ijk, tsdf, weight = volume.known_voxels()
    assert len(ijk) == len(tsdf) == len(weight) > 100
    t, w, s = volume.sample_voxels(ijk)
    np.testing.assert_array_equal(t, tsdf)
    np.testing.assert_array_equal(w, weight)
    assert (s != int(vdbmap.VoxelState.Unknown)).all()


def test_mesh_points_depth_and_trajectories_round_trip_through_files(tmp_path):
    volume = wall_volume(wall_points())
    vertices, triangles = vdbmap.extract_mesh(volume)
    assert vertices.dtype == np.float32 and triangles.dtype == np.int32 and len(triangles) > 50
    vdbmap.write_ply_mesh(tmp_path / "mesh.ply", (vertices, triangles))
    v2, t2 = vdbmap.read_triangle_mesh(tmp_path / "mesh.ply")
    np.testing.assert_array_equal(v2, vertices)
    np.testing.assert_array_equal(t2, triangles)

    points = wall_points()[:100]
    for ext in (".bin", ".ply", ".pcd"):
        vdbmap.write_point_cloud(str(tmp_path / f"p{ext}"), points)
        np.testing.assert_array_equal(vdbmap.read_point_cloud(tmp_path / f"p{ext}"), points)

    depth = np.linspace(0.5, 4.0, 48 * 64, dtype=np.float32).reshape(48, 64)
    assert vdbmap.write_depth_png(tmp_path / "d.png", depth, 0.001) == 0
    raw = vdbmap.read_png(tmp_path / "d.png")
    assert raw.dtype == np.uint16 and raw.shape == (48, 64)
    np.testing.assert_array_equal(raw, png_units(depth, 0.001))
    np.testing.assert_array_equal(vdbmap.read_depth_png(tmp_path / "d.png", 0.001),
                                  raw.astype(np.float32) * np.float32(0.001))

    stamps = np.array([0.0, 0.5, 1.25])
    poses = np.stack([pose(0.1 * i, 0.2, -0.3, yaw_deg=20.0 * i) for i in range(3)])
    vdbmap.write_tum_trajectory(tmp_path / "traj.txt", stamps, poses)
    t, T = vdbmap.read_tum_trajectory(tmp_path / "traj.txt")
    np.testing.assert_array_equal(t, stamps)
    np.testing.assert_allclose(T, poses, atol=1e-8)  # files hold 9 significant digits


def test_configs_start_from_the_cpp_defaults_and_edit_in_place():
    config = vdbmap.MapperConfig(mode="all", submap_frames=7)
    assert config.mode == vdbmap.ConsistencyMode.All and str(config.mode) == "all"
    config.tsdf.voxel_size_m = 0.04
    config.tsdf.weighting = "constant"
    assert config.tsdf.voxel_size_m == 0.04 and config.tsdf.weighting == vdbmap.Weighting.Constant
    mapper = vdbmap.Mapper(config)
    assert mapper.config.tsdf.voxel_size_m == 0.04 and mapper.config.submap_frames == 7
    assert "voxel_size_m=0.1" in repr(vdbmap.TsdfConfig())  # C++'s default, as repr shows it
    import copy
    c2 = copy.deepcopy(config)
    c2.tsdf.voxel_size_m = 0.2
    assert config.tsdf.voxel_size_m == 0.04


def expect_value_error(fn, *fragments):
    with pytest.raises(ValueError) as info:
        fn()
    for fragment in fragments:
        assert fragment in str(info.value), f"{fragment!r} not in {str(info.value)!r}"
    return str(info.value)


def test_wrong_shapes_and_dtypes_raise_value_errors_naming_the_argument():
    volume = vdbmap.TsdfVolume()
    T = pose()
    expect_value_error(lambda: volume.integrate(0, np.zeros((5, 2), np.float32), T),
                       "points_S", "(N, 3)", "float32 or float64", "shape (5, 2)", "float32")
    expect_value_error(lambda: volume.integrate(0, np.zeros((5, 3), np.int64), T), "points_S", "dtype int64")
    expect_value_error(lambda: volume.integrate(0, np.zeros(6, np.float32), T), "points_S", "shape (6,)")
    expect_value_error(lambda: volume.integrate(0, np.zeros((4, 3), np.float16), T), "points_S", "float16")
    expect_value_error(lambda: volume.integrate(0, "points", T), "points_S")
    expect_value_error(lambda: volume.integrate(0, wall_points(), np.eye(3)), "T_W_S", "(4, 4)", "shape (3, 3)")
    expect_value_error(lambda: volume.integrate(0, wall_points(), np.eye(4, dtype=np.int32)), "T_W_S", "int32")
    bad_row = np.eye(4)
    bad_row[3, 0] = 1.0
    expect_value_error(lambda: volume.integrate(0, wall_points(), bad_row), "T_W_S", "last row", "[0, 0, 0, 1]")
    K = small_camera()
    expect_value_error(lambda: vdbmap.back_project(np.zeros((48, 64, 1), np.float32), K), "depth", "(H, W)",
                       "shape (48, 64, 1)")
    expect_value_error(lambda: vdbmap.back_project(np.zeros((48, 64), np.uint16), K), "depth", "depth_scale")
    expect_value_error(lambda: vdbmap.back_project(wall_depth(), K, depth_scale=0.001), "depth_scale", "float32")
    expect_value_error(lambda: vdbmap.back_project(np.zeros((48, 64), np.int32), K), "depth", "int32")
    # The C++ check of the image size arrives with its own message.
    expect_value_error(lambda: vdbmap.back_project(np.zeros((5, 10), np.float32), K), "10x5", "64x48")
    expect_value_error(lambda: volume.sample(np.zeros((2, 4))), "points_W", "shape (2, 4)")
    expect_value_error(lambda: volume.sample_voxels(np.zeros((2, 3))), "ijk", "integers", "float64")
    expect_value_error(lambda: vdbmap.write_ply_mesh("/tmp/x.ply", (np.zeros((3, 3)), [[0, 1, 3]])),
                       "mesh triangles", "vertex 3", "3 vertices")
    expect_value_error(lambda: vdbmap.write_ply_mesh("/tmp/x.ply", np.zeros((3, 3))), "mesh", "(vertices, triangles)")
    mapper = vdbmap.Mapper(vdbmap.MapperConfig(mode="all"))
    expect_value_error(lambda: mapper.update_poses([pose()]), "poses", "dict")
    expect_value_error(lambda: mapper.update_poses({0: np.eye(3)}), "poses[0]", "(4, 4)")
    expect_value_error(lambda: mapper.update_poses({-1: pose()}), "poses", "non-negative")
    expect_value_error(lambda: mapper.reintegrate([0.0, 0.0]), "robot_W", "(3,)", "shape (2,)")
    expect_value_error(lambda: vdbmap.write_tum_trajectory("/tmp/t.txt", [0.0, 1.0], [pose()]), "poses", "(N, 4, 4)")
