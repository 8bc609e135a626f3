"""The Python examples run: integrate_log.py writes the map `vdbmap integrate` writes, and
read_with_pyopenvdb.py reads it with pyopenvdb and finds the same values, and explore_world.py
explores a small room, prints its summary and saves the map's mesh."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

import vdbmap
from conftest import PROJECT_ROOT


def run_example(name, *args):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    done = subprocess.run([sys.executable, str(PROJECT_ROOT / "examples" / name), *map(str, args)],
                          capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def test_integrate_log_example_writes_the_clis_map(cli, icl_nuim, tmp_path):
    out = run_example("integrate_log.py", icl_nuim, "-o", tmp_path / "py.vdb", "--mesh", tmp_path / "py.ply",
                      "--voxel-size", 0.05)
    assert "integrated 5 of 5 frames" in out
    cli("integrate", icl_nuim, "-o", tmp_path / "cli.vdb", "--voxel-size", 0.05)
    assert vdbmap.TsdfVolume.load(tmp_path / "py.vdb").exactly_equals(vdbmap.TsdfVolume.load(tmp_path / "cli.vdb"))
    assert len(vdbmap.read_triangle_mesh(tmp_path / "py.ply")[1]) > 1000


def test_read_with_pyopenvdb_example_agrees_with_our_reader(icl_nuim, tmp_path):
    pytest.importorskip("pyopenvdb")
    run_example("integrate_log.py", icl_nuim, "-o", tmp_path / "map.vdb", "--voxel-size", 0.1)
    out = run_example("read_with_pyopenvdb.py", tmp_path / "map.vdb")
    assert "grid tsdf: FloatGrid" in out and "grid weight: FloatGrid" in out
    assert "read the same" in out and out.strip().endswith("True")


def test_explore_world_example_prints_the_summary_and_saves_the_mesh(tmp_path):
    from test_sim import box_mesh
    vdbmap.write_ply_mesh(tmp_path / "room.ply", box_mesh([0.0, 0.0, 0.0], [4.0, 3.0, 2.5]))
    out = run_example("explore_world.py", tmp_path / "room.ply", "-o", tmp_path / "run", "--mesh",
                      tmp_path / "mesh.ply", "--voxel-size", 0.2, "--camera-scale", 0.125, "--ceiling", 0)
    assert "finished: True" in out and "collisions: 0" in out
    assert (tmp_path / "run" / "summary.json").exists()
    assert len(vdbmap.read_triangle_mesh(tmp_path / "mesh.ply")[1]) > 100
