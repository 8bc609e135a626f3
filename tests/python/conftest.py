"""Shared fixtures of the Python binding tests: where the CLI and the shared data are, and a small
analytic scene (a wall seen by a small depth camera) whose map values are known."""
from __future__ import annotations

import os
import pathlib
import subprocess

import numpy as np
import pytest

import vdbmap

PROJECT_ROOT = pathlib.Path(__file__).resolve().parents[2]
SHARED_DATA = pathlib.Path(os.environ.get("VDBMAP_SHARED_DATA", PROJECT_ROOT.parent / "shared" / "data"))
ICL_NUIM = SHARED_DATA / "iclnuim_livingroom_5frames_slambook2"


def cli_path() -> pathlib.Path:
    """The `vdbmap` program of the build the module comes from (build/lib/vdbmap*.so -> build/bin)."""
    if "VDBMAP_CLI" in os.environ:
        return pathlib.Path(os.environ["VDBMAP_CLI"])
    return pathlib.Path(vdbmap.__file__).resolve().parent.parent / "bin" / "vdbmap"


@pytest.fixture(scope="session")
def cli():
    path = cli_path()
    if not path.exists():
        pytest.skip(f"the vdbmap CLI is not at {path} (set VDBMAP_CLI)")

    def run(*args: str) -> str:
        done = subprocess.run([str(path), *map(str, args)], capture_output=True, text=True)
        assert done.returncode == 0, f"vdbmap {' '.join(map(str, args))} failed:\n{done.stdout}\n{done.stderr}"
        return done.stdout

    return run


@pytest.fixture(scope="session")
def icl_nuim() -> pathlib.Path:
    if not (ICL_NUIM / "pose.txt").exists():
        pytest.skip(f"shared data not found at {ICL_NUIM} (set VDBMAP_SHARED_DATA)")
    return ICL_NUIM


def small_camera() -> vdbmap.CameraIntrinsics:
    return vdbmap.CameraIntrinsics(width=64, height=48, fx=50.0, fy=50.0, cx=31.5, cy=23.5)


def wall_depth(distance_m: float = 2.0) -> np.ndarray:
    """A fronto-parallel wall: every pixel's depth (along the optical axis) is the same."""
    return np.full((48, 64), distance_m, dtype=np.float32)


def pose(x: float = 0.0, y: float = 0.0, z: float = 0.0, yaw_deg: float = 0.0) -> np.ndarray:
    """T_W_S translated by (x, y, z) and turned about the camera's y axis (OpenCV: down)."""
    c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    T = np.eye(4)
    T[:3, :3] = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    T[:3, 3] = [x, y, z]
    return T


def wall_points(distance_m: float = 2.0) -> np.ndarray:
    return vdbmap.back_project(wall_depth(distance_m), small_camera())


def png_units(depth_m: np.ndarray, depth_scale: float) -> np.ndarray:
    """The raw values write_depth_png stores: round(depth * (1 / scale)) in double, halves away from 0."""
    return np.floor(depth_m.astype(np.float64) * (1.0 / depth_scale) + 0.5).astype(np.uint16)
