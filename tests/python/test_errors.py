"""C++ exceptions arrive in Python with their messages: bad parameters and misuse as ValueError,
file problems as OSError (BadFrameError for one frame of a dataset), others as RuntimeError; an
unknown keyword is a TypeError, as in Python."""
from __future__ import annotations

import numpy as np
import pytest

import vdbmap
from conftest import pose, small_camera, wall_depth, wall_points


def test_out_of_range_config_fields_raise_value_error_naming_field_and_range():
    with pytest.raises(ValueError, match=r"TsdfConfig\.voxel_size_m must be in \[1e-4, 10\], got -1"):
        vdbmap.TsdfVolume(vdbmap.TsdfConfig(voxel_size_m=-1.0))
    with pytest.raises(ValueError, match=r"IntegratorConfig\.min_range_m"):
        vdbmap.IntegratorConfig(min_range_m=9.0, max_range_m=5.0).validate()
    with pytest.raises(ValueError, match=r"MapperConfig\.submap_frames"):
        vdbmap.Mapper(vdbmap.MapperConfig(submap_frames=0))
    with pytest.raises(ValueError, match="weighting must be constant or inverse_square, got 'linear'"):
        vdbmap.TsdfConfig(weighting="linear")
    with pytest.raises(ValueError, match=r"TsdfConfig\.weight_scale must be in \{0\} or the powers of two in \[1024, 1048576\], got 3000"):
        vdbmap.TsdfConfig(weight_scale=3000).validate()
    with pytest.raises(TypeError, match="TsdfConfig\\(\\) got an unexpected keyword argument 'voxel_size'"):
        vdbmap.TsdfConfig(voxel_size=0.1)


def test_misuse_of_frames_raises_value_error_and_changes_nothing():
    volume = vdbmap.TsdfVolume()
    volume.integrate(3, wall_points(), pose())
    before = vdbmap.TsdfVolume(volume.config)
    before.integrate(3, wall_points(), pose())
    with pytest.raises(ValueError, match="frame 3 is already integrated"):
        volume.integrate(3, wall_points(), pose(z=1.0))
    with pytest.raises(ValueError, match="frame 4 cannot be de-integrated: it was never integrated"):
        volume.deintegrate(4, wall_points(), pose())
    sheared = pose()
    sheared[0, 1] = 0.5
    with pytest.raises(ValueError, match="not a rigid transform"):
        volume.integrate(5, wall_points(), sheared)
    assert volume.exactly_equals(before)
    mapper = vdbmap.Mapper()
    mapper.add_depth_frame(0, 0.0, wall_depth(), small_camera(), pose())
    with pytest.raises(ValueError, match="frame 0 was already given to the mapper"):
        mapper.add_depth_frame(0, 0.1, wall_depth(), small_camera(), pose())


def test_file_problems_raise_os_error_naming_the_file(tmp_path):
    missing = tmp_path / "nothing_here.vdb"
    with pytest.raises(OSError, match="nothing_here.vdb"):
        vdbmap.TsdfVolume.load(missing)
    with pytest.raises(OSError, match="no_such_folder"):
        vdbmap.TsdfVolume().save(tmp_path / "no_such_folder" / "map.vdb")
    with pytest.raises(OSError, match="no_log"):
        vdbmap.open_dataset(tmp_path / "no_log")
    (tmp_path / "bad.txt").write_text("0.0 1 2 3 0 0 0 1\n1.0 oops\n")
    with pytest.raises(OSError, match="bad.txt:2"):
        vdbmap.read_tum_trajectory(tmp_path / "bad.txt")
    (tmp_path / "not_a.png").write_text("plain text")
    with pytest.raises(OSError, match="not a PNG"):
        vdbmap.read_depth_png(tmp_path / "not_a.png", 0.001)


def test_a_bad_frame_is_an_os_error_with_its_index(tmp_path):
    sensor = vdbmap.SensorInfo(intrinsics=small_camera(), depth_scale=0.001)
    with vdbmap.LogWriter(tmp_path / "log", sensor) as log:
        log.add_depth_frame(0.0, wall_depth(), pose())
        log.add_depth_frame(0.1, wall_depth(1.5), pose())
    (tmp_path / "log" / "depth").joinpath(sorted(p.name for p in (tmp_path / "log" / "depth").iterdir())[1]).unlink()
    source = vdbmap.open_dataset(tmp_path / "log")
    assert len(source) == 2
    with pytest.raises(vdbmap.BadFrameError) as info:
        source[1]
    assert isinstance(info.value, OSError)
    assert info.value.frame_index == 1
    assert "frame 1" in str(info.value)
    with pytest.raises(vdbmap.BadFrameError):
        vdbmap.replay_log(source, vdbmap.Mapper(), vdbmap.ReplayConfig())
    result = vdbmap.replay_log(source, vdbmap.Mapper(), vdbmap.ReplayConfig(on_bad_frame="skip"))
    assert result.frames_integrated == 1 and result.frames_skipped == 1
    assert result.bad_frames[0].index == 1 and "frame 1" in result.bad_frames[0].message


def test_indices_out_of_range_raise_index_error(tmp_path):
    sensor = vdbmap.SensorInfo(intrinsics=small_camera())
    with vdbmap.LogWriter(tmp_path / "log", sensor) as log:
        log.add_depth_frame(0.0, wall_depth(), pose())
    source = vdbmap.open_dataset(tmp_path / "log")
    assert source[-1].index == 0
    with pytest.raises(IndexError):
        source[1]
    assert [f.index for f in source] == [0]  # iteration stops at the IndexError
    with pytest.raises(IndexError, match="no frame 9"):
        vdbmap.Mapper().keyframe(9)


def test_a_closed_log_writer_raises_runtime_error(tmp_path):
    log = vdbmap.LogWriter(tmp_path / "log", vdbmap.SensorInfo(intrinsics=small_camera()))
    log.close()
    with pytest.raises(RuntimeError, match="the log is closed"):
        log.add_depth_frame(0.0, wall_depth(), pose())


def test_progress_callbacks_run_with_the_gil_and_their_exceptions_stop_the_replay(tmp_path):
    sensor = vdbmap.SensorInfo(intrinsics=small_camera())
    with vdbmap.LogWriter(tmp_path / "log", sensor) as log:
        for i in range(4):
            log.add_depth_frame(0.1 * i, wall_depth(2.0 + 0.1 * i), pose(x=0.05 * i))
    source = vdbmap.open_dataset(tmp_path / "log")
    seen = []
    result = vdbmap.replay_log(source, vdbmap.Mapper(), vdbmap.ReplayConfig(progress=lambda d, t: seen.append((d, t))))
    assert result.frames_integrated == 4 and seen == [(1, 4), (2, 4), (3, 4), (4, 4)]

    def stop(done, total):
        if done == 2:
            raise KeyError("stop here")

    with pytest.raises(KeyError, match="stop here"):
        vdbmap.replay_log(source, vdbmap.Mapper(), vdbmap.ReplayConfig(progress=stop))
