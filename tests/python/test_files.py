"""Maps written from Python are ordinary vdbmap files: C++ (the CLI's `info`, TsdfVolume.load)
and Debian's pyopenvdb read them with the same values; logs written from Python read back frame
for frame."""
from __future__ import annotations

import copy
import json

import numpy as np
import pytest

import vdbmap
from conftest import png_units, pose, small_camera, wall_depth, wall_points


def two_wall_volume() -> vdbmap.TsdfVolume:
    volume = vdbmap.TsdfVolume(vdbmap.TsdfConfig(voxel_size_m=0.05, truncation_vox=4.0, weighting="constant"))
    volume.integrate(0, wall_points(2.0), pose(yaw_deg=-20.0))
    volume.integrate(1, wall_points(1.5), pose(x=0.3, yaw_deg=25.0))
    return volume


def test_save_then_load_is_exact_and_keeps_the_frame_registry(tmp_path):
    volume = two_wall_volume()
    volume.save(tmp_path / "map.vdb")
    assert vdbmap.TsdfVolume.exact_state_path(tmp_path / "map.vdb").name == "map.exact.vdb"
    loaded = vdbmap.TsdfVolume.load(str(tmp_path / "map.vdb"))
    assert loaded.has_exact_state and loaded.exactly_equals(volume)
    assert loaded.config.truncation_vox == 4.0 and loaded.config.weighting == vdbmap.Weighting.Constant
    assert sorted(loaded.integrated_poses()) == [0, 1]
    loaded.deintegrate(1, wall_points(1.5), pose(x=0.3, yaw_deg=25.0))
    only0 = vdbmap.TsdfVolume(volume.config)
    only0.integrate(0, wall_points(2.0), pose(yaw_deg=-20.0))
    assert loaded.exactly_equals(only0)


def test_a_far_range_map_weighs_far_rays_and_keeps_its_weight_scale_through_save_and_load(cli, tmp_path):
    # A wall 80 m away seen by a narrow camera: at the scale of maps up to 5 m (1024 units per ray
    # of weight 1) its rays would weigh round(1024 / 80^2) = 0 and add nothing.
    narrow = vdbmap.CameraIntrinsics(width=8, height=8, fx=1000.0, fy=1000.0, cx=3.5, cy=3.5)
    volume = vdbmap.TsdfVolume(vdbmap.TsdfConfig(voxel_size_m=0.2), vdbmap.IntegratorConfig(max_range_m=100.0))
    assert vdbmap.TsdfVolume().config.weight_scale == 1024
    assert volume.config.weight_scale == 2**20  # 40 units at 100 m need 400,000
    for i in range(8):
        volume.integrate_depth(i, np.full((8, 8), 80.0, np.float32), narrow, pose(x=0.01 * i))
    tsdf, weight, state = volume.sample(np.array([[0.0, 0.0, 80.0], [0.0, 0.0, 40.0]]))
    assert list(state) == [int(vdbmap.VoxelState.Occupied), int(vdbmap.VoxelState.Free)]
    np.testing.assert_allclose(weight, 8 / 80.0**2, rtol=1 / 80)
    volume.save(tmp_path / "far.vdb")
    loaded = vdbmap.TsdfVolume.load(str(tmp_path / "far.vdb"))
    assert loaded.config.weight_scale == 2**20 and loaded.exactly_equals(volume)
    assert vdbmap.inspect_map_file(tmp_path / "far.vdb").weight_scale == 2**20
    assert json.loads(cli("info", tmp_path / "far.vdb", "--json"))["weight_scale"] == 2**20


def test_a_map_saved_from_python_is_read_by_the_cli(cli, tmp_path):
    volume = two_wall_volume()
    volume.save(tmp_path / "map.vdb")
    info = json.loads(cli("info", tmp_path / "map.vdb", "--json"))
    grids = {g["name"]: g for g in info["grids"]}
    known = len(volume.known_voxels()[0])
    assert grids["tsdf"]["active_voxels"] == grids["weight"]["active_voxels"] == known
    assert info["has_exact_state"] is True
    assert float(info["metadata"]["voxel_size_m"]) == 0.05
    assert info["metadata"]["weighting"] == "constant"
    # The binding's own view of the file is the CLI's.
    mine = vdbmap.inspect_map_file(tmp_path / "map.vdb")
    assert {g.name: g.active_voxels for g in mine.grids} == {n: g["active_voxels"] for n, g in grids.items()}
    assert mine.metadata["weighting"] == "constant" and mine.has_exact_state
    cli("mesh", tmp_path / "map.vdb", "-o", tmp_path / "mesh.ply")
    for a, b in zip(vdbmap.read_triangle_mesh(tmp_path / "mesh.ply"), vdbmap.extract_mesh(volume)):
        np.testing.assert_array_equal(a, b)


def test_a_map_saved_from_python_is_read_by_pyopenvdb_beside_our_module(tmp_path):
    pyopenvdb = pytest.importorskip("pyopenvdb")
    volume = two_wall_volume()
    volume.save(tmp_path / "map.vdb")
    grids, metadata = pyopenvdb.readAll(str(tmp_path / "map.vdb"))
    by_name = {g.name: g for g in grids}
    assert set(by_name) == {"tsdf", "weight"}
    assert metadata["weighting"] == "constant"
    tsdf, weight = by_name["tsdf"], by_name["weight"]
    assert tsdf.transform.voxelSize()[0] == pytest.approx(0.05)
    ijk, t, w = volume.known_voxels()
    assert tsdf.activeVoxelCount() == weight.activeVoxelCount() == len(ijk)
    acc_t, acc_w = tsdf.getConstAccessor(), weight.getConstAccessor()
    for k in range(0, len(ijk), max(1, len(ijk) // 500)):
        c = tuple(int(x) for x in ijk[k])
        assert acc_t.getValue(c) == t[k] and acc_w.getValue(c) == w[k]
        assert acc_t.isValueOn(c)
    # Dense copies agree too, over the whole active box.
    (lo, hi) = tsdf.evalActiveVoxelBoundingBox()
    dense = np.zeros(tuple(h - l + 1 for l, h in zip(lo, hi)), dtype=np.float32)
    tsdf.copyToArray(dense, ijk=lo)
    np.testing.assert_array_equal(dense[tuple((ijk - np.array(lo)).T)], t)


def test_a_log_written_from_python_reads_back_frame_for_frame(tmp_path):
    K = small_camera()
    sensor = vdbmap.SensorInfo(intrinsics=K, depth_scale=0.001, max_range_m=4.0)
    depths = [wall_depth(2.0 + 0.25 * i) for i in range(3)]
    depths[1][10, 10] = 0.0
    poses = [pose(0.1 * i, 0.0, 0.0, yaw_deg=5.0 * i) for i in range(3)]
    with vdbmap.LogWriter(tmp_path / "log", sensor) as log:
        for i in range(3):
            assert log.add_depth_frame(0.2 * i, depths[i], poses[i]) == i
            log.add_ground_truth(0.2 * i, poses[i])
        log.add_correction(0.4, [0.0, 0.2], np.stack([pose(0.01), pose(0.11, yaw_deg=5.0)]))
        assert len(log) == 3
    source = vdbmap.open_dataset(tmp_path / "log", "log")
    assert vdbmap.detect_dataset_format(tmp_path / "log") == vdbmap.DatasetFormat.Log
    assert len(source) == 3 and source.sensor.max_range_m == 4.0 and source.sensor.intrinsics.fx == K.fx
    for i, frame in enumerate(source):
        assert frame.is_depth and frame.points_S is None
        np.testing.assert_array_equal(frame.depth, png_units(depths[i], 0.001) * np.float32(0.001))
        np.testing.assert_allclose(frame.T_W_S, poses[i], atol=1e-8)
        assert frame.timestamp_s == pytest.approx(0.2 * i)
    (event,) = source.corrections
    assert event.event_frame == 2
    stamps, corrected = event.poses
    np.testing.assert_array_equal(stamps, [0.0, 0.2])
    np.testing.assert_allclose(corrected[0], pose(0.01), atol=1e-8)
    gt_stamps, gt = source.ground_truth
    assert len(gt_stamps) == 3
    assert source.find_frame(0.2) == 1 and source.find_frame(0.3) is None


def test_mapper_reintegration_equals_integrating_at_the_corrected_pose():
    K = small_camera()
    config = vdbmap.MapperConfig(mode="all")
    config.tsdf.voxel_size_m = 0.05
    corrected = pose(0.2, 0.0, 0.1, yaw_deg=12.0)

    mapper = vdbmap.Mapper(config)
    mapper.add_depth_frame(0, 0.0, wall_depth(2.0), K, pose())
    mapper.add_depth_frame(1, 0.1, wall_depth(1.8), K, pose(0.1, yaw_deg=10.0))
    assert mapper.take_dirty_region() is not None and mapper.take_dirty_region() is None
    assert mapper.update_poses({1: corrected, 99: pose()}) == 1  # unknown ids are skipped
    assert mapper.queued_frames == 1
    report = mapper.reintegrate([0.0, 0.0, 0.0])
    assert report.frames == 1 and report.queued_left == 0
    assert mapper.take_dirty_region() is not None
    keyframe = mapper.keyframe(1)
    np.testing.assert_array_equal(keyframe.T_W_S_integrated, corrected)
    assert keyframe.integrated and mapper.keyframe_ids() == [0, 1]

    fresh = vdbmap.Mapper(config)
    fresh.add_depth_frame(0, 0.0, wall_depth(2.0), K, pose())
    fresh.add_depth_frame(1, 0.1, wall_depth(1.8), K, corrected)
    assert mapper.volume().exactly_equals(fresh.volume())
    # The stored keyframe decodes to the depth image the mapper integrated.
    by_hand = vdbmap.TsdfVolume(config.tsdf, config.integrator)
    by_hand.integrate_depth(0, mapper.keyframe(0).depth(), K, pose())
    by_hand.integrate_depth(1, keyframe.depth(), K, corrected)
    assert by_hand.exactly_equals(fresh.volume())


def test_a_saved_mapper_loads_and_corrects_exactly(tmp_path):
    K = small_camera()
    config = vdbmap.MapperConfig(mode="keyframes")
    config.tsdf.voxel_size_m = 0.05
    mapper = vdbmap.Mapper(config)
    mapper.add_depth_frame(0, 0.0, wall_depth(2.0), K, pose())
    mapper.add_depth_frame(1, 0.1, wall_depth(1.8), K, pose(0.1, yaw_deg=10.0))
    mapper.reintegrate_all([0.0, 0.0, 0.0])
    mapper.save(tmp_path / "map.vdb")
    assert vdbmap.Mapper.keyframes_path(tmp_path / "map.vdb") == tmp_path / "map.keyframes"
    assert (tmp_path / "map.keyframes").exists() and (tmp_path / "map.exact.vdb").exists()

    loaded = vdbmap.Mapper.load(tmp_path / "map.vdb")
    assert loaded.config.mode == vdbmap.ConsistencyMode.All
    assert loaded.keyframe_ids() == mapper.keyframe_ids()
    corrected = pose(0.2, 0.0, 0.1, yaw_deg=12.0)
    assert loaded.update_poses({1: corrected}) == 1
    loaded.reintegrate_all([0.0, 0.0, 0.0])
    fresh = vdbmap.Mapper(vdbmap.MapperConfig(mode="none", tsdf=config.tsdf))
    fresh.add_depth_frame(0, 0.0, mapper.keyframe(0).depth(), K, pose())
    fresh.add_depth_frame(1, 0.1, mapper.keyframe(1).depth(), K, corrected)
    assert loaded.volume().exactly_equals(fresh.volume())

    (tmp_path / "map.keyframes").write_bytes(b"garbage")
    with pytest.raises(OSError, match="map.keyframes"):
        vdbmap.Mapper.load(tmp_path / "map.vdb")


def test_volume_copies_are_deep_and_mapper_snapshots_are_independent():
    volume = two_wall_volume()
    shallow, deep = copy.copy(volume), copy.deepcopy(volume)
    volume.deintegrate(1, wall_points(1.5), pose(x=0.3, yaw_deg=25.0))
    assert shallow.exactly_equals(deep) and not shallow.exactly_equals(volume)
    mapper = vdbmap.Mapper(vdbmap.MapperConfig(mode="submap", submap_frames=1))
    mapper.add_depth_frame(0, 0.0, wall_depth(), small_camera(), pose())
    snapshot = mapper.volume()
    count = snapshot.active_voxel_count
    mapper.add_depth_frame(1, 0.1, wall_depth(1.2), small_camera(), pose(z=-1.0))
    assert snapshot.active_voxel_count == count  # the fused map was rebuilt; the snapshot is unchanged
    assert mapper.volume().active_voxel_count > count and mapper.stats.submaps == 2


def test_surface_evaluation_of_a_wall_against_its_plane():
    volume = vdbmap.TsdfVolume(vdbmap.TsdfConfig(voxel_size_m=0.05))
    volume.integrate(0, wall_points(2.0), pose())
    mesh = vdbmap.extract_mesh(volume)
    ground_truth = (np.array([[-3, -3, 2], [3, -3, 2], [3, 3, 2], [-3, 3, 2]], np.float32), [[0, 1, 2], [0, 2, 3]])
    result = vdbmap.evaluate_surface(mesh, ground_truth, vdbmap.EvalConfig(completeness_threshold_m=0.1))
    assert result.reconstructed_vertices == len(mesh[0])
    assert result.accuracy_rmse_m < 0.25 * 0.05  # a quarter voxel on a plane seen head-on
    assert 0.0 < result.completeness < 1.0  # the camera sees only part of the 6 x 6 m plane
    distance = vdbmap.SurfaceDistance(ground_truth, 0.05)
    np.testing.assert_allclose(distance.distance([[0.0, 0.0, 1.0], [0.5, 0.5, 2.5]]), [1.0, 0.5], atol=1e-9)
    assert distance.samples().shape[1] == 3
