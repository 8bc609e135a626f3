"""Long calls release the GIL: a Python thread that ticks every millisecond keeps ticking while
integrate, replay_log, save and load run. (A call that held the GIL would let it tick only at the
call's edges.)"""
from __future__ import annotations

import threading
import time

import numpy as np

import vdbmap
from conftest import pose

# A call must let the ticker run at least this often to count as releasing the GIL (replay takes
# the GIL back once per frame for its progress callback: 5 frames, so a few ticks at most).
MIN_TICKS = 20


def ticks_during(call) -> int:
    ticks = 0
    stop = threading.Event()

    def tick():
        nonlocal ticks
        while not stop.is_set():
            time.sleep(0.001)
            ticks += 1

    ticker = threading.Thread(target=tick)
    ticker.start()
    time.sleep(0.02)
    before = ticks
    call()
    during = ticks - before
    stop.set()
    ticker.join()
    return during


def big_wall_volume():
    # 640x480 rays through 0.04 m voxels: a few hundred milliseconds of integration on one thread.
    points = vdbmap.back_project(np.full((480, 640), 3.0, np.float32), vdbmap.CameraIntrinsics())
    volume = vdbmap.TsdfVolume(vdbmap.TsdfConfig(voxel_size_m=0.04), vdbmap.IntegratorConfig(threads=1))
    return volume, points


def test_integrate_and_files_release_the_gil(tmp_path):
    volume, points = big_wall_volume()
    assert ticks_during(lambda: volume.integrate(0, points, pose())) >= MIN_TICKS
    assert ticks_during(lambda: volume.deintegrate(0, points, pose())) >= MIN_TICKS
    volume.integrate(0, points, pose())
    # Saving and loading a map of this size take tens of milliseconds: repeat them.
    assert ticks_during(lambda: [volume.save(tmp_path / "map.vdb") for _ in range(5)]) >= MIN_TICKS
    assert ticks_during(lambda: [vdbmap.TsdfVolume.load(tmp_path / "map.vdb") for _ in range(10)]) >= MIN_TICKS


def test_replay_releases_the_gil(icl_nuim):
    source = vdbmap.open_dataset(icl_nuim)
    config = vdbmap.MapperConfig(mode="none")
    # 2 cm voxels: tens of milliseconds a frame on one thread, however fast the integrator gets.
    config.tsdf.voxel_size_m = 0.02
    config.integrator.threads = 1
    assert ticks_during(lambda: vdbmap.replay_log(source, vdbmap.Mapper(config))) >= MIN_TICKS
