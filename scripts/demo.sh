#!/usr/bin/env bash
# Sets up (Debian packages, Release build into build/) and runs the main job:
#  1. the simulated vehicle explores the AWS small house world at odometry drift s3 with the
#     mapper (keyframes mode, 0.1 m voxels) and the exploration planner with active loop closure
#     (--alc on) in closed loop, and writes
#     the run folder demo_out/explore_house_s3/ (log/, map.vdb, mesh.ply, trajectories,
#     summary.json), printing the summary; about two minutes;
#  2. the 500 real 7-Scenes RedKitchen depth frames integrated at 5 cm into
#     demo_out/redkitchen.vdb with its mesh and JSON summary (a few seconds), and a picture
#     rendered by OpenVDB's vdb_render when it is installed.
# Extra arguments go to `vdbmap explore` (e.g. --drift s1 --seed 2, or --alc off). See README.md.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
vdbmap_install_packages
vdbmap_build_targets vdbmap_cli
cd "$vdbmap_root"
shared="${VDBMAP_SHARED_DATA:-$vdbmap_root/../shared/data}"
house="$shared/aws_small_house_world/small_house_visual_mesh.ply"
kitchen="$shared/7scenes_redkitchen_tsdf_fusion_python"
for d in "$house" "$kitchen"; do
  [ -e "$d" ] || { echo "demo: $d is missing (set VDBMAP_SHARED_DATA to the shared data folder)" >&2; exit 1; }
done
mkdir -p demo_out
vdbmap="$vdbmap_build/bin/vdbmap"

echo "== 1. exploring the small house at drift s3 =="
alc=(--alc on)  # unless the extra arguments choose
for arg in "$@"; do [[ "$arg" == --alc* ]] && alc=(); done
"$vdbmap" explore --world "$house" --drift s3 --seed 1 "${alc[@]}" -o demo_out/explore_house_s3 --overwrite "$@"
echo "demo_out/explore_house_s3/summary.json:"
cat demo_out/explore_house_s3/summary.json

echo "== 2. integrating 7-Scenes RedKitchen (500 real Kinect frames) =="
"$vdbmap" integrate "$kitchen" -o demo_out/redkitchen.vdb --voxel-size 0.05 \
  --mesh demo_out/redkitchen.ply --json demo_out/redkitchen.json
"$vdbmap" info demo_out/redkitchen.vdb
if command -v vdb_render > /dev/null; then
  vdb_render demo_out/redkitchen.vdb demo_out/redkitchen.png -name tsdf -res 960x720 \
    -translate -0.2,-1.2,-1.4 -lookat 0,0.2,1.2 -up 0,-1,0 -fov 70
  echo "rendered demo_out/redkitchen.png"
fi
