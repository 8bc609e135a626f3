"""Closed-loop exploration from Python (vdbmap.sim): a small room explored at coarse voxels and a
reduced camera resolution (seconds) finishes without collisions; `explore` writes the run folder
and returns summary.json's content; `run_exploration` returns TUM trajectories, counters and the
final Mapper, which the rest of the module can query; the run releases the GIL; configs start from
C++'s defaults (as the CLI shows them) and their shortcuts edit the nested structs."""
from __future__ import annotations

import gc
import json
import threading
import time

import numpy as np
import pytest

import vdbmap
import vdbmap.sim as sim
from test_sim import box_mesh, cli_default, small_camera_config

# One 4 x 3 x 2.5 m room, seen at 0.2 m voxels by an 80x60 camera with the default field of view.
ROOM_MIN = np.array([0.0, 0.0, 0.0])
ROOM_MAX = np.array([4.0, 3.0, 2.5])
START = np.array([2.0, 1.5, 1.2])
# A drifting run (s2) must still keep this far from every wall: the vehicle's radius.
SUMMARY_KEYS = {
    "exploration_time_s", "path_length_m", "coverage", "loop_closures", "collisions", "planner_ms_median",
    "planner_ms_max", "frames_total", "keyframes_kept", "accuracy_rmse_m", "completeness", "finished", "description",
    "mode", "voxel_size_m", "max_time_s", "start", "box", "min_clearance_m", "vehicle_radius_m", "replans",
    "replans_failed", "collision_risk_replans", "target_failures", "visit_failures", "path_failures",
    "blacklisted_clusters", "holds",
    "map_update_ms_median", "frame_wall_ms_median", "reintegrated_frames", "estimate_error_rmse_m",
    "estimate_error_max_m", "odometry_error_final_m", "observable_surface", "wall_s", "budgets",
    "map_alignment", "keyframe_error_aligned_rmse_m", "accuracy_aligned_rmse_m",
}
# Quaternions of TUM rows are unit to rounding.
UNIT_QUATERNION_TOLERANCE = 1e-9
# A run that released the GIL lets a 1 ms ticker run at least this often (progress takes the GIL
# back once a frame, briefly).
MIN_TICKS = 20


@pytest.fixture(scope="module")
def room():
    return sim.World(box_mesh(ROOM_MIN, ROOM_MAX))


def tiny_config(drift="s1"):
    config = sim.ExplorationConfig()
    config.simulator.camera = small_camera_config(80, 60)
    config.simulator.camera.far_clip_m = sim.ExplorationConfig().simulator.camera.far_clip_m
    config.drift = drift
    config.seed = 3
    config.voxel_size_m = 0.2
    config.box = (ROOM_MIN, ROOM_MAX)
    config.start = START
    config.max_time_s = 120.0
    config.set_budgets("counted")  # the same run however loaded the machine is
    return config


@pytest.fixture(scope="module")
def run(room):
    """One run_exploration, with the ticks a 1 ms Python thread made while it ran."""
    ticks, stop = [0], threading.Event()

    def tick():
        while not stop.is_set():
            time.sleep(0.001)
            ticks[0] += 1

    progress = []
    ticker = threading.Thread(target=tick)
    ticker.start()
    try:
        result = sim.run_exploration(room, tiny_config("s2"), progress=progress.append)
    finally:
        stop.set()
        ticker.join()
    return result, ticks[0], progress


def test_a_tiny_exploration_finishes_without_collisions(run):
    result, _, progress = run
    assert result.finished and result.collisions == 0
    assert result.min_clearance_m >= tiny_config().vehicle_radius_m
    assert result.path_length_m > 0.5 and result.frames_total > 0
    assert result.planner_counters.replans == len(result.planner_ms) > 0
    counters = result.planner_counters
    assert counters.visit_failures + counters.path_failures <= counters.target_failures
    assert result.planner_ms_max == pytest.approx(result.planner_ms.max())
    # progress came after every frame, in order, and the last update finished the run
    assert [p.frames for p in progress] == list(range(1, result.frames_total + 1))
    assert progress[-1].status == vdbmap.planner.ExplorationStatus.Finished


def test_run_exploration_returns_tum_trajectories_and_the_mapper(run):
    result, _, _ = run
    for trajectory in (result.trajectory_true, result.trajectory_estimate):
        assert trajectory.shape == (result.frames_total, 8) and trajectory.dtype == np.float64
        assert (np.diff(trajectory[:, 0]) > 0).all()
        np.testing.assert_allclose(np.linalg.norm(trajectory[:, 4:], axis=1), 1.0, atol=UNIT_QUATERNION_TOLERANCE)
    np.testing.assert_array_equal(result.trajectory_true[:, 0], result.trajectory_estimate[:, 0])
    # s2 drifts: the estimate the mapper used is not the truth
    assert np.abs(result.trajectory_true[:, 1:4] - result.trajectory_estimate[:, 1:4]).max() > 0.0

    mapper = result.mapper
    assert isinstance(mapper, vdbmap.Mapper) and mapper.keyframes_kept == result.keyframes_kept
    assert mapper.queued_frames == 0 and mapper.stats.frames_total == result.frames_total
    vertices, triangles = vdbmap.extract_mesh(mapper.volume())
    assert len(triangles) > 100
    # The mesh lies on the room's walls (within two voxels of one of its six planes).
    to_walls = np.minimum(np.abs(vertices - ROOM_MIN), np.abs(vertices - ROOM_MAX)).min(axis=1)
    assert np.median(to_walls) < 2 * 0.2


def test_counted_budgets_repeat_a_run_exactly(room):
    config = tiny_config("s2")
    config.set_budgets("counted")  # what `vdbmap explore` uses by default
    assert cli_default("explore", "--budgets") == str(sim.BudgetMode.Counted) == "counted"
    assert config.planner.path.max_iterations > 0 and config.planner.tour.max_iterations > 0
    assert config.mapper.reintegration.budget_frames > 0
    first, second = sim.run_exploration(room, config), sim.run_exploration(room, config)
    assert first.planner_counters.replans >= 3
    np.testing.assert_array_equal(first.trajectory_true, second.trajectory_true)
    np.testing.assert_array_equal(first.trajectory_estimate, second.trajectory_estimate)

    config.set_budgets(sim.BudgetMode.WallClock)  # back to the defaults
    defaults = sim.ExplorationConfig()
    assert config.planner.path.max_iterations == 0 and config.planner.tour.max_iterations == 0
    assert config.planner.path.time_limit_s == defaults.planner.path.time_limit_s
    assert config.mapper.reintegration.budget_ms == defaults.mapper.reintegration.budget_ms
    with pytest.raises(ValueError, match="counted or wall-clock"):
        config.set_budgets("iterations")


def test_the_mapper_keeps_its_result_alive(room):
    config = tiny_config()
    config.max_time_s = 2.0  # a short, unfinished run is enough here
    mapper = sim.run_exploration(room, config).mapper
    gc.collect()
    assert mapper.stats.frames_total > 0 and mapper.volume().active_voxel_count > 0


def test_the_run_releases_the_gil(run):
    result, ticks, _ = run
    assert result.wall_s > 0.1  # long enough to measure
    assert ticks >= MIN_TICKS


def test_explore_writes_the_run_folder_and_returns_its_summary(room, tmp_path):
    lines = []
    summary = sim.explore(room, tiny_config(), tmp_path / "run", description="pytest", report=lines.append)
    assert SUMMARY_KEYS <= summary.keys()
    assert summary == json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["finished"] and summary["collisions"] == 0 and summary["description"] == "pytest"
    assert summary["mode"] == "keyframes" and summary["voxel_size_m"] == 0.2
    assert summary["start"] == [*START, 0.0] and summary["box"] == {"min": [*ROOM_MIN], "max": [*ROOM_MAX]}
    assert summary["coverage"] > 0.5 and lines and lines[-1].startswith("wrote")
    for name in ("map.vdb", "mesh.ply", "trajectory_true.txt", "trajectory_odom.txt", "log/frames.csv"):
        assert (tmp_path / "run" / name).exists(), name
    # The recorded log replays with every frame; the map file loads.
    source = vdbmap.open_dataset(tmp_path / "run" / "log")
    assert len(source) == summary["frames_total"]
    assert vdbmap.TsdfVolume.load(tmp_path / "run" / "map.vdb").active_voxel_count > 0

    with pytest.raises(RuntimeError, match="already holds an exploration run"):
        sim.explore(room, tiny_config(), tmp_path / "run")


def test_errors_map_to_python_exceptions(room, tmp_path):
    config = tiny_config()
    config.box = None
    with pytest.raises(ValueError, match="box"):
        sim.run_exploration(room, config)
    config = tiny_config()
    config.start = [0.05, 0.05, 0.05]  # inside the wall's clearance
    with pytest.raises(ValueError):
        sim.run_exploration(room, config)
    config = tiny_config()
    config.max_time_s = -1.0
    with pytest.raises(ValueError, match="max_time_s"):
        sim.explore(room, config, tmp_path / "run")
    with pytest.raises(ValueError, match=r"box min: expected a \(3,\)"):
        config.box = ([0, 0], [1, 1, 1])
    with pytest.raises(ValueError, match="start"):
        config.start = np.zeros((3, 1))
    with pytest.raises(ValueError, match="s9"):
        config.drift = "s9"

    def interrupt(progress):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sim.run_exploration(room, tiny_config(), progress=interrupt)


def test_exploration_config_defaults_and_shortcuts(room):
    config = sim.ExplorationConfig()
    # C++'s defaults, as `vdbmap explore --help` shows them.
    assert config.voxel_size_m == float(cli_default("explore", "--voxel-size"))
    assert config.max_time_s == float(cli_default("explore", "--max-time-s"))
    assert str(config.mode) == cli_default("explore", "--mode") == "keyframes"
    assert str(config.simulator.loop_closure) == cli_default("explore", "--loop-closure")
    assert config.drift.is_zero() and config.box is None and config.vehicle_radius_m == 0.2
    # The exploration's camera reports far surfaces (30 m) so rays carve free space up to the range.
    assert config.simulator.camera.far_clip_m == 30.0 and sim.SimulatorConfig().camera.far_clip_m == 5.0
    assert config.planner.path.time_limit_s == 0.1 and config.planner.cost_path.time_limit_s == 0.01
    # Active loop closure is off unless asked for (`vdbmap explore --alc off`), epsilon as the CLI's.
    assert config.planner.alc_enabled is False and cli_default("explore", "--alc") == "off"
    assert config.planner.alc.epsilon == float(cli_default("explore", "--epsilon")) == 0.2
    assert config.planner.alc.finish_loop_age_s == float(cli_default("explore", "--finish-loop-age")) == 10.0
    config.planner.alc.epsilon = 0.5
    assert config.planner.alc.epsilon == 0.5
    with pytest.raises(ValueError, match="finish_search_radius_m"):
        vdbmap.planner.AlcConfig(finish_search_radius_m=0.0).validate()
    with pytest.raises(ValueError, match="epsilon"):
        vdbmap.planner.AlcConfig(epsilon=-1.0).validate()

    config.seed = 11
    assert (config.simulator.drift.seed, config.planner.path.seed, config.planner.cost_path.seed,
            config.planner.tour.seed, config.planner.alc.tour.seed) == (11, 11, 11, 11, 11)
    assert config.planner.safety.odometry is None
    config.drift = "s3"
    assert config.simulator.drift.sigma2_xyz_m2ps2 == 5e-2 and config.simulator.drift.seed == 11
    # Setting a drift declares it to the safety layer, as `vdbmap explore --drift s3` does.
    declared, expected = config.planner.safety.odometry, sim.odometry_drift_of(config.simulator.drift)
    assert declared.position_m_per_sqrt_s == expected.position_m_per_sqrt_s > 0.0
    assert declared.yaw_rad_per_sqrt_s == expected.yaw_rad_per_sqrt_s > 0.0
    config.drift = sim.DriftConfig(mu_xyz_mps=0.01)
    assert config.simulator.drift.mu_xyz_mps == 0.01
    config.drift.sigma2_yaw_rad2ps2 = 0.03  # the shortcut is the nested struct itself
    assert config.simulator.drift.sigma2_yaw_rad2ps2 == 0.03
    config.mode = "all"
    config.voxel_size_m = 0.15
    assert config.mapper.mode == vdbmap.ConsistencyMode.All and config.mapper.tsdf.voxel_size_m == 0.15
    config.planner.viewpoint.camera.max_range_m = 3.0
    assert config.planner.viewpoint.camera.max_range_m == 3.0
    # Revisit rounds are off by default, as `vdbmap explore --revisit-rounds`.
    assert config.planner.revisit_rounds == int(cli_default("explore", "--revisit-rounds")) == 0
    # Departures away from the velocity cost FUEL's 1.5 s per radian, as `vdbmap explore --w-dir`.
    assert config.planner.cost.w_dir == float(cli_default("explore", "--w-dir")) == 1.5
    # The final sweep over small clusters is on by default, as `vdbmap explore --final-min-cluster-size`.
    assert config.planner.final_min_cluster_size == int(cli_default("explore", "--final-min-cluster-size")) == 30
    # ... visiting each pocket left when it begins once, as `vdbmap explore --final-sweep once`.
    assert config.planner.final_sweep == vdbmap.planner.FinalSweepScope.PocketsOnce
    assert cli_default("explore", "--final-sweep") == "once"
    # Flown paths fall back to the lattice where RRTConnect finds nothing; priced legs do not.
    assert config.planner.path.search == vdbmap.planner.PathSearch.SamplingThenGrid
    assert config.planner.cost_path.search == vdbmap.planner.PathSearch.Sampling
    # The fallback viewpoint search is on by default and reachable as a nested struct.
    fallback = config.planner.viewpoint.fallback
    assert fallback.enabled is True and fallback.min_visible_fraction == 0.5
    config.planner.viewpoint.fallback.enabled = False
    assert config.planner.viewpoint.fallback.enabled is False
    with pytest.raises(ValueError, match="ViewpointFallback.min_visible_fraction"):
        vdbmap.planner.ViewpointFallback(min_visible_fraction=0.0).validate()

    for_world = sim.ExplorationConfig.for_world(room)
    lo, hi = for_world.box
    np.testing.assert_array_equal(lo, ROOM_MIN)
    np.testing.assert_array_equal(hi, ROOM_MAX)
    np.testing.assert_array_equal(for_world.start, sim.default_start_position(room, for_world.box))
    assert room.distance(for_world.start[None, :])[0] >= 0.6


def test_the_safety_layer_is_set_from_python_and_its_counters_come_back(room):
    config = tiny_config("s2")
    config.set_budgets("counted")
    assert not config.planner.safety.enabled  # off by default, as `vdbmap explore --safety`
    assert cli_default("explore", "--safety") == "off"
    assert cli_default("explore", "--safety-window-s") == str(int(vdbmap.planner.RecentFramesConfig().window_s))
    assert cli_default("explore", "--safety-max-window-s") == str(int(vdbmap.planner.SafetyConfig().max_window_s))
    # With the layer, seen free space is free and thin structure is the recent frames', as the CLI's
    # defaults say.
    assert vdbmap.planner.SafetyConfig().seen_free_is_free and cli_default("explore", "--safety-seen-free") == "on"
    assert not vdbmap.planner.SafetyConfig().map_thin_obstacles and vdbmap.planner.SafetyConfig().map_thin_without_drift
    assert cli_default("explore", "--safety-map-thin") == "without-drift"
    # A recent surface that a newer frame saw free is cleared, in the library and the CLI.
    assert vdbmap.planner.RecentFramesConfig().newer_free_clears
    assert cli_default("explore", "--safety-free-clears") == "on"
    # No drift declared: the base window; s1's drift (none) declared: the longest; s3's: the base.
    safety = vdbmap.planner.SafetyConfig()
    assert safety.odometry is None and safety.window_s() == safety.recent.window_s
    assert not safety.effective_map_thin_obstacles()  # no odometry declared: it may drift
    safety.odometry = sim.odometry_drift_of(sim.DriftConfig.preset("s1"))
    assert safety.window_s() == safety.max_window_s
    # Without drift the map's thin structure is read (no ghosts), unless switched off.
    assert safety.effective_map_thin_obstacles()
    safety.map_thin_without_drift = False
    assert not safety.effective_map_thin_obstacles()
    safety.map_thin_without_drift = True
    safety.odometry = sim.odometry_drift_of(sim.DriftConfig.preset("s3"))
    assert safety.odometry.position_m_per_sqrt_s == pytest.approx((5e-2 / 200) ** 0.5)
    assert safety.window_s() == safety.recent.window_s
    assert not safety.effective_map_thin_obstacles()
    safety.map_thin_obstacles = True
    assert safety.effective_map_thin_obstacles()
    safety.map_thin_obstacles = False
    # The vertical margin holds under drift (s3's, or none declared), not without it (s1's).
    assert cli_default("explore", "--safety-vertical-margin") == str(safety.vertical_margin_m)
    assert safety.effective_vertical_margin_m() == safety.vertical_margin_m == 0.2
    # It grows with the map's age to 2 sigmas of s3's vertical drift, at most 0.3 m.
    assert float(cli_default("explore", "--safety-vertical-sigmas")) == safety.vertical_margin_sigmas
    assert cli_default("explore", "--safety-vertical-margin-max") == str(safety.max_vertical_margin_m)
    # The way ahead is seen beside its middle too, a vehicle's clearance to either side.
    assert cli_default("explore", "--safety-look-side") == str(safety.look_side_m) == str(safety.clearance_m)
    assert safety.look_steep and cli_default("explore", "--safety-look-steep") == "on"
    assert safety.seen_until_arrival and cli_default("explore", "--safety-seen-until-arrival") == "on"
    # A way counts as seen by frames as old as the window, or as the declared drift bears (s3: 9.4 s, s4: 6 s).
    assert safety.window_s() == 10.0 and safety.seen_age_s() == pytest.approx(9.4, abs=0.05)
    s4 = vdbmap.planner.SafetyConfig()
    s4.odometry = sim.odometry_drift_of(sim.DriftConfig.preset("s4"))
    assert s4.window_s() == 10.0 and s4.seen_age_s() == pytest.approx(6.0, abs=0.05)
    # Near a recent surface, with the rule on, only frames whose drift stays within 0.1 m (s3: 2.6 s).
    assert safety.near_drift_tolerance_m == 0.0 and cli_default("explore", "--safety-near-tolerance") == "0"
    assert safety.near_seen_age_s() == safety.seen_age_s()
    safety.near_drift_tolerance_m = 0.1
    assert safety.near_seen_age_s() == pytest.approx(2.6, abs=0.05)
    safety.near_drift_tolerance_m = 0.0
    assert safety.effective_vertical_margin_m(60.0) == pytest.approx(2.0 * safety.odometry.axis_displacement_m(60.0))
    assert safety.effective_vertical_margin_m(1000.0) == safety.max_vertical_margin_m == 0.3
    safety.odometry = sim.odometry_drift_of(sim.DriftConfig.preset("s1"))
    assert safety.effective_vertical_margin_m() == 0.0
    config.planner.safety.enabled = True
    config.planner.safety.recent.window_s = 5.0
    config.planner.safety.recent.pool_px = 0
    with pytest.raises(ValueError, match="RecentFramesConfig.pool_px"):
        sim.run_exploration(room, config)
    config.planner.safety.recent.pool_px = 4
    result = sim.run_exploration(room, config)
    assert result.finished and result.collisions == 0
    counters = result.planner_counters
    assert counters.replans >= counters.emergency_stops + counters.look_stops
    # The way the vehicle may fly before it faces it is a trajectory field, checked like the others.
    trajectory = vdbmap.planner.TrajectoryConfig(yaw_along_travel=True, free_way_m=2.0)
    trajectory.validate()
    trajectory.free_way_m = -1.0
    with pytest.raises(ValueError, match="TrajectoryConfig.free_way_m"):
        trajectory.validate()
