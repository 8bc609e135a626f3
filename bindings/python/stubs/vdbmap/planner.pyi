"""Type stubs of `vdbmap.planner` (bindings/python/bind_planner.cpp): the exploration planner's
parameters (vdbmap.sim.ExplorationConfig.planner), its counters and statuses."""
from __future__ import annotations

from typing import Any, ClassVar, Optional

import numpy as np
import numpy.typing as npt

class _Enum:
    __members__: ClassVar[dict[str, Any]]
    def __eq__(self, other: object) -> bool: ...
    def __ne__(self, other: object) -> bool: ...
    def __hash__(self) -> int: ...
    def __index__(self) -> int: ...
    def __int__(self) -> int: ...
    @property
    def name(self) -> str: ...
    @property
    def value(self) -> int: ...

_F64 = npt.NDArray[np.float64]
_BoxF = Optional[tuple[_F64, _F64]]

class FrontierConfig:
    """Frontier clusters (FUEL's cluster_min, cluster_size_xy, down_sample)."""
    min_cluster_size: int
    split_radius_xy_m: float
    sample_stride_vox: int
    def __init__(self, **kwargs: Any) -> None: ...
    def validate(self) -> None: ...
    def __copy__(self) -> FrontierConfig: ...
    def __deepcopy__(self, memo: dict[Any, Any]) -> FrontierConfig: ...

class CameraFrustum:
    """The camera the planner scores viewpoints with."""
    tan_half_fov_x: float
    tan_half_fov_y: float
    min_range_m: float
    max_range_m: float
    def __init__(self, **kwargs: Any) -> None: ...
    def validate(self) -> None: ...
    def __copy__(self) -> CameraFrustum: ...
    def __deepcopy__(self, memo: dict[Any, Any]) -> CameraFrustum: ...

class ViewpointFallback:
    """The second, closer and taller ring search for clusters with no ring viewpoint."""
    enabled: bool
    ring_radius_min_m: float
    ring_radius_max_m: float
    ring_count: int
    height_offsets_m: list[float]
    min_clearance_m: float
    min_visible_fraction: float
    def __init__(self, **kwargs: Any) -> None: ...
    def validate(self) -> None: ...
    def __copy__(self) -> ViewpointFallback: ...
    def __deepcopy__(self, memo: dict[Any, Any]) -> ViewpointFallback: ...

class ViewpointConfig:
    """Viewpoints sampled on rings around each cluster."""
    ring_radius_min_m: float
    ring_radius_max_m: float
    ring_count: int
    angle_step_deg: float
    height_offsets_m: list[float]
    min_clearance_m: float
    min_visible_samples: int
    look_into_unknown: bool
    unknown_entry_reach_vox: int
    voxel_rule_fallback: bool
    vertical_into_unknown: bool
    camera: CameraFrustum
    fallback: ViewpointFallback
    def __init__(self, **kwargs: Any) -> None: ...
    def validate(self) -> None: ...
    def __copy__(self) -> ViewpointConfig: ...
    def __deepcopy__(self, memo: dict[Any, Any]) -> ViewpointConfig: ...

class CostConfig:
    """Cost between viewpoints."""
    v_max_m_s: float
    yaw_rate_max_rad_s: float
    w_dir: float
    unreachable_cost_s: float
    def __init__(self, **kwargs: Any) -> None: ...
    def validate(self) -> None: ...
    def __copy__(self) -> CostConfig: ...
    def __deepcopy__(self, memo: dict[Any, Any]) -> CostConfig: ...

class PathSearch(_Enum):
    """How a path is searched when the straight segment is blocked."""
    Sampling: ClassVar[PathSearch]
    Grid: ClassVar[PathSearch]
    SamplingThenGrid: ClassVar[PathSearch]
    def __init__(self, value: int) -> None: ...

class PathConfig:
    """Collision-free paths in the map (straight line, else OMPL RRTConnect or a lattice search)."""
    clearance_m: float
    check_step_m: float
    time_limit_s: float
    max_iterations: int
    rrt_range_m: float
    simplify_rounds: int
    seed: int
    search: PathSearch
    def __init__(self, **kwargs: Any) -> None: ...
    def validate(self) -> None: ...
    def __copy__(self) -> PathConfig: ...
    def __deepcopy__(self, memo: dict[Any, Any]) -> PathConfig: ...

class TourConfig:
    """The global tour's ATSP solver."""
    time_limit_s: float
    seed: int
    max_iterations: int
    max_stale_iterations: int
    max_planned_pairs: int
    def __init__(self, **kwargs: Any) -> None: ...
    def validate(self) -> None: ...
    def __copy__(self) -> TourConfig: ...
    def __deepcopy__(self, memo: dict[Any, Any]) -> TourConfig: ...

class RefinementConfig:
    """Local viewpoint refinement (FUEL's refined_*)."""
    max_clusters: int
    radius_m: float
    top_viewpoints: int
    max_planned_edges: int
    max_decay: float
    min_distance_m: float
    def __init__(self, **kwargs: Any) -> None: ...
    def validate(self) -> None: ...
    def __copy__(self) -> RefinementConfig: ...
    def __deepcopy__(self, memo: dict[Any, Any]) -> RefinementConfig: ...

class TrajectoryConfig:
    """Minimum-time trajectories along paths."""
    v_max_m_s: float
    a_max_m_s2: float
    yaw_rate_max_rad_s: float
    yaw_acc_max_rad_s2: float
    normal_acc_share: float
    corner_fraction: float
    ds_m: float
    clearance_m: float
    check_step_m: float
    corner_shrink_steps: int
    yaw_along_travel: bool
    yaw_lead_s: float
    start_facing_rad: float
    free_way_m: float
    lead_in_at_speed: bool
    def __init__(self, **kwargs: Any) -> None: ...
    def validate(self) -> None: ...
    def __copy__(self) -> TrajectoryConfig: ...
    def __deepcopy__(self, memo: dict[Any, Any]) -> TrajectoryConfig: ...

class AlcConfig:
    """Active loop closure (docs/planner.md); the history and cluster parameters stay at their C++ defaults."""
    epsilon: float
    search_radius_m: float
    initial_period_s: float
    give_up_timeout_s: float
    suspension_s: float
    loop_quiet_s: float
    max_failures_per_cluster: int
    finish_loop_age_s: float
    finish_search_radius_m: float
    max_finish_detours: int
    unreachable_cost_s: float
    tour: TourConfig
    def __init__(self, **kwargs: Any) -> None: ...
    def validate(self) -> None: ...
    def __copy__(self) -> AlcConfig: ...
    def __deepcopy__(self, memo: dict[Any, Any]) -> AlcConfig: ...

class EscapeConfig:
    """Retreats and straight escapes out of a blocked start."""
    flown_positions_kept: int
    retreat_reach_m: float
    escape_reach_m: float
    def __init__(self, **kwargs: Any) -> None: ...
    def validate(self) -> None: ...
    def __copy__(self) -> EscapeConfig: ...
    def __deepcopy__(self, memo: dict[Any, Any]) -> EscapeConfig: ...

class RecentFramesConfig:
    """The safety layer's recent depth frames (max_range_m and free_margin_m are set by the exploration manager)."""
    window_s: float
    dense_s: float
    sparse_period_s: float
    pool_px: int
    max_range_m: float
    free_margin_m: float
    newer_free_clears: bool
    def __init__(self, **kwargs: Any) -> None: ...
    def validate(self) -> None: ...
    def __copy__(self) -> RecentFramesConfig: ...
    def __deepcopy__(self, memo: dict[Any, Any]) -> RecentFramesConfig: ...

class OdometryDrift:
    """What the odometry is expected to drift (a VIO's noise spec): random walks and biases in position per axis and in yaw."""
    position_m_per_sqrt_s: float
    position_bias_m_per_s: float
    yaw_rad_per_sqrt_s: float
    yaw_bias_rad_per_s: float
    def __init__(self, **kwargs: Any) -> None: ...
    def displacement_m(self, t_s: float, lever_m: float, path_m: float = 0.0) -> float: ...
    def axis_displacement_m(self, t_s: float) -> float: ...
    def longest_within(self, tolerance_m: float, lever_m: float, min_s: float, max_s: float) -> float: ...
    def validate(self) -> None: ...
    def __copy__(self) -> OdometryDrift: ...
    def __deepcopy__(self, memo: dict[Any, Any]) -> OdometryDrift: ...

class SafetyConfig:
    """The drift-free safety layer near the vehicle: recent depth frames as obstacles, emergency stops, looking along the way before flying it."""
    enabled: bool
    face_travel: bool
    recent: RecentFramesConfig
    odometry: Optional[OdometryDrift]
    max_window_s: float
    drift_tolerance_m: float
    drift_lever_m: float
    clearance_m: float
    look_margin_m: float
    look_side_m: float
    look_steep: bool
    seen_until_arrival: bool
    path_drift: PathDriftScope
    near_drift_tolerance_m: float
    max_chained_looks: int
    seen_free_is_free: bool
    map_thin_obstacles: bool
    map_thin_without_drift: bool
    vertical_margin_m: float
    vertical_margin_sigmas: float
    max_vertical_margin_m: float
    def __init__(self, **kwargs: Any) -> None: ...
    def window_s(self) -> float: ...
    def seen_age_s(self) -> float: ...
    def near_seen_age_s(self) -> float: ...
    def effective_map_thin_obstacles(self) -> bool: ...
    def effective_vertical_margin_m(self, map_age_s: float = ...) -> float: ...
    def validate(self) -> None: ...
    def __copy__(self) -> SafetyConfig: ...
    def __deepcopy__(self, memo: dict[Any, Any]) -> SafetyConfig: ...

class PathDriftScope(_Enum):
    """Where the safety layer counts the path flown since a frame in its drift."""
    Off: ClassVar[PathDriftScope]
    NearSurfaces: ClassVar[PathDriftScope]
    Everywhere: ClassVar[PathDriftScope]
    def __init__(self, value: int) -> None: ...

class FinalSweepScope(_Enum):
    """Which small clusters the final sweep visits."""
    All: ClassVar[FinalSweepScope]
    Pockets: ClassVar[FinalSweepScope]
    PocketsOnce: ClassVar[FinalSweepScope]
    def __init__(self, value: int) -> None: ...

class ExplorationManagerConfig:
    """The exploration manager (FUEL-style); box_W is required."""
    box_W: _BoxF
    frontier: FrontierConfig
    viewpoint: ViewpointConfig
    cost: CostConfig
    path: PathConfig
    cost_path: PathConfig
    tour: TourConfig
    refinement: RefinementConfig
    trajectory: TrajectoryConfig
    start_free_half_size_m: _F64
    initial_turn: bool
    viewpoint_margin_z_m: float
    alc_enabled: bool
    alc: AlcConfig
    safety: SafetyConfig
    replan_time_left_s: float
    replan_covered_after_s: float
    replan_period_s: float
    covered_fraction: float
    collision_radius_m: float
    max_failures: int
    all_failed_spacing_s: float
    revisit_rounds: int
    final_min_cluster_size: int
    late_large_min_visible_samples: int
    final_sweep: FinalSweepScope
    max_targets_per_replan: int
    keep_target: bool
    initial_turn_parts: int
    risk_check_spacing_vox: float
    escape: EscapeConfig
    max_chained_escapes: int
    max_chained_backtracks: int
    def __init__(self, **kwargs: Any) -> None: ...
    def validate(self) -> None: ...
    def __copy__(self) -> ExplorationManagerConfig: ...
    def __deepcopy__(self, memo: dict[Any, Any]) -> ExplorationManagerConfig: ...

class ExplorationStatus(_Enum):
    """What one exploration update decided."""
    Continue: ClassVar[ExplorationStatus]
    Planned: ClassVar[ExplorationStatus]
    NoFrontier: ClassVar[ExplorationStatus]
    Failed: ClassVar[ExplorationStatus]
    Finished: ClassVar[ExplorationStatus]
    def __init__(self, value: int) -> None: ...

class ExplorationCounters:
    """Counters of the exploration manager."""
    @property
    def updates(self) -> int: ...
    @property
    def replans(self) -> int: ...
    @property
    def replans_failed(self) -> int: ...
    @property
    def collision_risks(self) -> int: ...
    @property
    def target_failures(self) -> int: ...
    @property
    def visit_failures(self) -> int: ...
    @property
    def path_failures(self) -> int: ...
    @property
    def blacklisted(self) -> int: ...
    @property
    def holds(self) -> int: ...
    @property
    def escapes(self) -> int: ...
    @property
    def retreats(self) -> int: ...
    @property
    def revisit_rounds(self) -> int: ...
    @property
    def final_sweep_clusters(self) -> int: ...
    @property
    def late_large_clusters(self) -> int: ...
    @property
    def emergency_stops(self) -> int: ...
    @property
    def look_stops(self) -> int: ...
    @property
    def looks_resumed(self) -> int: ...
