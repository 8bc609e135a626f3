"""Two Python threads on one TsdfVolume or Mapper take turns (a per-object lock held while the GIL is
released) instead of racing on its OpenVDB trees: the map they build together is bit-identical to
the one built by one thread, while a third thread keeps reading it. A replay's progress callback,
which runs while the replay holds the mapper, may still read that mapper."""
from __future__ import annotations

import threading

import numpy as np

import vdbmap
from conftest import pose, small_camera, wall_depth

FRAMES = 24


def depth_of(i: int) -> np.ndarray:
    # A tilted wall per frame, so that frames overlap in part and touch the same leaves.
    d = wall_depth(1.5 + 0.05 * (i % 7)).copy()
    d += np.linspace(0.0, 0.3, d.shape[1], dtype=np.float32)[None, :]
    return d


def frame_pose(i: int) -> np.ndarray:
    return pose(x=0.04 * i, z=-0.02 * (i % 5), yaw_deg=3.0 * (i % 11))


def run_threads(work_of_thread, reader=None):
    """Runs work_of_thread(k) for k = 0, 1 in two threads (and `reader` in a third until they end);
    re-raises the first exception of any thread."""
    errors = []
    done = threading.Event()

    def guarded(fn, *args):
        try:
            fn(*args)
        except BaseException as e:  # noqa: BLE001 - reported to the test below
            errors.append(e)

    workers = [threading.Thread(target=guarded, args=(work_of_thread, k)) for k in range(2)]
    readers = []
    if reader is not None:
        readers.append(threading.Thread(target=guarded, args=(lambda: [reader() for _ in iter(done.is_set, True)],)))
    for t in readers + workers:
        t.start()
    for t in workers:
        t.join()
    done.set()
    for t in readers:
        t.join()
    if errors:
        raise errors[0]


def volume_config():
    return vdbmap.TsdfConfig(voxel_size_m=0.02), vdbmap.IntegratorConfig(threads=2)


def test_two_threads_integrating_into_one_volume_give_the_single_thread_map():
    shared = vdbmap.TsdfVolume(*volume_config())
    reads = []

    def integrate_half(k):
        for i in range(k, FRAMES, 2):
            shared.integrate_depth(i, depth_of(i), small_camera(), frame_pose(i))
            if i % 4 == k:  # and take some back out, so that voxels are removed while others read
                shared.deintegrate_depth(i, depth_of(i), small_camera(), frame_pose(i))

    def read():
        reads.append(shared.active_voxel_count)
        shared.sample(np.array([[0.1, 0.0, 1.6], [0.3, 0.1, 1.7]]))

    run_threads(integrate_half, reader=read)

    alone = vdbmap.TsdfVolume(*volume_config())
    for i in range(FRAMES):
        if i % 4 not in (0, 1):
            alone.integrate_depth(i, depth_of(i), small_camera(), frame_pose(i))
    assert reads, "the reader thread never ran"
    assert shared.frame_count == alone.frame_count
    assert shared.exactly_equals(alone)


def test_two_threads_adding_frames_to_one_mapper_give_the_single_thread_map():
    config = vdbmap.MapperConfig(mode="all")
    config.tsdf.voxel_size_m = 0.02
    shared = vdbmap.Mapper(config)

    def add_half(k):
        for i in range(k, FRAMES, 2):
            shared.add_depth_frame(i, 0.1 * i, depth_of(i), small_camera(), frame_pose(i))

    run_threads(add_half, reader=lambda: (shared.stats, shared.queued_frames, shared.keyframe_ids()))

    alone = vdbmap.Mapper(config)
    for i in range(FRAMES):
        alone.add_depth_frame(i, 0.1 * i, depth_of(i), small_camera(), frame_pose(i))
    assert shared.keyframe_ids() == alone.keyframe_ids()
    assert shared.volume().exactly_equals(alone.volume())


def test_a_replay_progress_callback_may_read_the_mapper_it_writes(tmp_path):
    sensor = vdbmap.SensorInfo(intrinsics=small_camera())
    with vdbmap.LogWriter(tmp_path / "log", sensor) as log:
        for i in range(4):
            log.add_depth_frame(0.1 * i, depth_of(i), frame_pose(i))
    mapper = vdbmap.Mapper()
    seen = []
    vdbmap.replay_log(vdbmap.open_dataset(tmp_path / "log"), mapper,
                      vdbmap.ReplayConfig(progress=lambda done, total: seen.append(mapper.stats.frames_total)))
    assert seen == [1, 2, 3, 4]
