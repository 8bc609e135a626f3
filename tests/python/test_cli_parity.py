"""The bindings compute what the C++ CLI computes: the same log integrated by `vdbmap integrate`
and from Python (replay_log, or frame by frame from raw uint16 PNG arrays) gives bit-identical
maps, meshes and summary numbers. The engine's sums are exact integers, so equality is exact
even where re-integration runs under a time budget."""
from __future__ import annotations

import json

import numpy as np
import pytest

import vdbmap

VOXEL_M = 0.05


def mapper_like_the_cli(source: vdbmap.FrameSource, mode: str) -> vdbmap.Mapper:
    """The configuration `vdbmap integrate --voxel-size 0.05 --mode <mode>` builds."""
    config = vdbmap.MapperConfig(mode=mode)
    config.tsdf.voxel_size_m = VOXEL_M
    config.integrator.min_range_m = source.sensor.min_range_m
    config.integrator.max_range_m = source.sensor.max_range_m
    return vdbmap.Mapper(config)


def cli_integrate(cli, log, out_dir, mode: str) -> dict:
    cli("integrate", log, "-o", out_dir / "cli.vdb", "--voxel-size", VOXEL_M, "--mode", mode,
        "--mesh", out_dir / "cli.ply", "--json", out_dir / "cli.json")
    return json.loads((out_dir / "cli.json").read_text())


def assert_same_map(cli_dir, volume: vdbmap.TsdfVolume, summary: dict) -> None:
    cli_map = vdbmap.TsdfVolume.load(cli_dir / "cli.vdb")
    assert cli_map.has_exact_state
    assert cli_map.exactly_equals(volume)
    assert summary["active_voxels"] == volume.active_voxel_count
    for a, b in zip(cli_map.known_voxels(), volume.known_voxels()):
        np.testing.assert_array_equal(a, b)
    vertices, triangles = vdbmap.extract_mesh(volume)
    assert summary["mesh_triangles"] == len(triangles) > 1000
    cli_vertices, cli_triangles = vdbmap.read_triangle_mesh(cli_dir / "cli.ply")
    np.testing.assert_array_equal(cli_vertices, vertices)
    np.testing.assert_array_equal(cli_triangles, triangles)


def test_replay_log_equals_the_cli_on_icl_nuim(cli, icl_nuim, tmp_path):
    summary = cli_integrate(cli, icl_nuim, tmp_path, "keyframes")
    source = vdbmap.open_dataset(icl_nuim)
    assert source.format == summary["format"] == "iclnuim"
    mapper = mapper_like_the_cli(source, "keyframes")
    result = vdbmap.replay_log(source, mapper)
    assert result.frames_integrated == summary["frames_integrated"] == 5
    assert mapper.keyframes_kept == summary["keyframes_kept"]
    assert_same_map(tmp_path, mapper.volume(), summary)


def test_frames_added_one_by_one_from_raw_png_arrays_equal_the_cli(cli, icl_nuim, tmp_path):
    summary = cli_integrate(cli, icl_nuim, tmp_path, "all")
    source = vdbmap.open_dataset(icl_nuim)
    sensor = source.sensor
    assert sensor.invalid_depth_raw == 0  # so raw 0 is the only invalid value, as in the binding
    mapper = mapper_like_the_cli(source, "all")
    for record in source.records():
        raw = vdbmap.read_png(record.file)
        assert raw.dtype == np.uint16
        mapper.add_depth_frame(record.index, record.timestamp_s, raw, sensor.intrinsics, record.T_W_S,
                               depth_scale=sensor.depth_scale)
    assert mapper.keyframes_kept == summary["keyframes_kept"] == 5
    assert_same_map(tmp_path, mapper.volume(), summary)


@pytest.mark.parametrize("mode", ["all", "keyframes"])
def test_a_drifting_log_with_a_correction_gives_the_cli_map(cli, icl_nuim, tmp_path, mode):
    log = tmp_path / "drift_log"
    cli("drift-log", icl_nuim, "-o", log, "--sigma-translation", 0.02, "--sigma-yaw-deg", 1.0, "--seed", 5)
    summary = cli_integrate(cli, log, tmp_path, mode)
    source = vdbmap.open_dataset(log)
    assert source.format == "log" and len(source.corrections) == 1
    mapper = mapper_like_the_cli(source, mode)
    result = vdbmap.replay_log(source, mapper)
    assert result.correction_events == summary["correction_events"] == 1
    assert mapper.stats.reintegrated_frames == summary["reintegrated_frames"] > 0
    assert mapper.queued_frames == 0
    assert_same_map(tmp_path, mapper.volume(), summary)
    # The corrected map is not the drifted one: the correction did something.
    uncorrected = mapper_like_the_cli(source, mode)
    vdbmap.replay_log(source, uncorrected, vdbmap.ReplayConfig(apply_corrections=False))
    assert not uncorrected.volume().exactly_equals(mapper.volume())
