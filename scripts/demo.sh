#!/usr/bin/env bash
# Sets up (Debian packages, Release build into build/) and runs the main job: the 500 real
# 7-Scenes RedKitchen depth frames integrated at 5 cm into demo_out/redkitchen.vdb, its mesh
# demo_out/redkitchen.ply, a JSON summary and a picture rendered by OpenVDB's vdb_render.
# Extra arguments go to `vdbmap integrate` (e.g. --voxel-size 0.02). See README.md.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
vdbmap_install_packages
vdbmap_build_targets vdbmap_cli
cd "$vdbmap_root"
data="${VDBMAP_SHARED_DATA:-$vdbmap_root/../shared/data}/7scenes_redkitchen_tsdf_fusion_python"
[ -d "$data" ] || { echo "demo: the 7-Scenes data is not at $data (set VDBMAP_SHARED_DATA)" >&2; exit 1; }
mkdir -p demo_out
"$vdbmap_build/bin/vdbmap" integrate "$data" -o demo_out/redkitchen.vdb --voxel-size 0.05 \
  --mesh demo_out/redkitchen.ply --json demo_out/redkitchen.json "$@"
"$vdbmap_build/bin/vdbmap" info demo_out/redkitchen.vdb
if command -v vdb_render > /dev/null; then
  vdb_render demo_out/redkitchen.vdb demo_out/redkitchen.png -name tsdf -res 960x720 \
    -translate -0.2,-1.2,-1.4 -lookat 0,0.2,1.2 -up 0,-1,0 -fov 70
  echo "rendered demo_out/redkitchen.png"
fi
