#!/usr/bin/env bash
# Sets up (Debian packages, Release build into build/) and runs the main job:
#  1. the simulated vehicle explores the AWS small house world (embedded in data/worlds) at
#     odometry drift s3 with the mapper (keyframes mode, 0.1 m voxels) and the exploration planner
#     with active loop closure (--alc on) and the safety layer (--safety on) in closed loop, and
#     writes the run folder demo_out/explore_house_s3/ (log/, map.vdb, mesh.ply, trajectories,
#     coverage.csv, cycles.csv, summary.json, and report.html: one page to open in a browser),
#     printing the summary; a few minutes;
#  2. when the shared data is there (VDBMAP_SHARED_DATA, default ../shared/data), the 500 real
#     7-Scenes RedKitchen depth frames integrated at 5 cm into demo_out/redkitchen.vdb with its
#     mesh, JSON summary and report page (a few seconds), and a picture rendered by OpenVDB's
#     vdb_render when it is installed; without the data this step says so in one line and is skipped.
# Extra arguments go to `vdbmap explore` (e.g. --drift s1 --seed 2, --alc off or --safety off).
# See README.md.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
vdbmap_install_packages
vdbmap_build_targets vdbmap_cli
cd "$vdbmap_root"
shared="${VDBMAP_SHARED_DATA:-$vdbmap_root/../shared/data}"
house="$vdbmap_root/data/worlds/small_house/small_house_visual_mesh.ply"  # embedded (MIT-0)
kitchen="$shared/7scenes_redkitchen_tsdf_fusion_python"
mkdir -p demo_out
vdbmap="$vdbmap_build/bin/vdbmap"

echo "== 1. exploring the small house at drift s3 =="
alc=(--alc on)        # unless the extra arguments choose
safety=(--safety on)  # the safety layer guards the flight against the drifted map (docs/exploration.md)
for arg in "$@"; do
  [[ "$arg" == --alc* ]] && alc=()
  [[ "$arg" == --safety || "$arg" == --safety=* ]] && safety=()  # not --safety-window-s etc.
done
"$vdbmap" explore --world "$house" --drift s3 --seed 1 "${alc[@]}" "${safety[@]}" --report -o demo_out/explore_house_s3 \
  --overwrite "$@"
echo "demo_out/explore_house_s3/summary.json:"
cat demo_out/explore_house_s3/summary.json

if [ ! -d "$kitchen" ]; then
  echo "== 2. skipped: 7-Scenes RedKitchen is not at $kitchen (its licence forbids shipping it; README.md, section Data, says where to get it)"
  exit 0
fi
echo "== 2. integrating 7-Scenes RedKitchen (500 real Kinect frames) =="
"$vdbmap" integrate "$kitchen" -o demo_out/redkitchen.vdb --voxel-size 0.05 \
  --mesh demo_out/redkitchen.ply --json demo_out/redkitchen.json
"$vdbmap" info demo_out/redkitchen.vdb
"$vdbmap" report demo_out/redkitchen.vdb --summary demo_out/redkitchen.json -o demo_out/redkitchen_report.html
if command -v vdb_render > /dev/null; then
  vdb_render demo_out/redkitchen.vdb demo_out/redkitchen.png -name tsdf -res 960x720 \
    -translate -0.2,-1.2,-1.4 -lookat 0,0.2,1.2 -up 0,-1,0 -fov 70
  echo "rendered demo_out/redkitchen.png"
fi
