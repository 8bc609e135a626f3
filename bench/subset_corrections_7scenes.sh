#!/usr/bin/env bash
# Keyframe corrections on real frames (#24's measurement, folder logs): 7-Scenes RedKitchen with a
# drifting copy of its poses (vdbmap drift-log, 0.6 deg/frame yaw random walk: 12.2 deg at the
# loop), cut at the loop frame, integrated every 4th frame (122 frames), corrected by a loop event
# that lists the true pose of every 4th integrated frame only. Maps: no correction, online `all`
# and `keyframes` (the correction interpolated to every frame), and offline `vdbmap reintegrate`
# of the uncorrected `all` map with the same poses; each map's RMSE against the true-pose map;
# whether the offline map equals the online one bit for bit. Then the same from a ROS bag.
#   bench/subset_corrections_7scenes.sh [OUTDIR]     (needs ../shared/data, build/bin/vdbmap)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
V="$root/build/bin/vdbmap"
D="${VDBMAP_SHARED_DATA:-$root/../shared/data}/7scenes_redkitchen_tsdf_fusion_python"
out="${1:-/tmp/vdbmap_subset_corrections}"
mkdir -p "$out" && cd "$out"
"$V" drift-log "$D" -o log --sigma-yaw-deg 0.6 --seed 1 --overwrite
/usr/bin/python3 - <<'PY'
import glob, os, shutil
lines = open('log/frames.csv').read().splitlines()
header, rows = lines[0], lines[1:]
event_file = glob.glob('log/corrections/*.txt')[0]
stamp = os.path.basename(event_file)[:-4]
n = [i for i, r in enumerate(rows) if r.startswith(stamp + ',')][0] + 1
rows = rows[:n]
gt = [l for l in open('log/groundtruth.txt').read().splitlines() if l and not l.startswith('#')][:n]
corr = [l for l in open(event_file).read().splitlines() if l and not l.startswith('#')]
thin = [c for i, c in enumerate(corr) if i % 16 == 0]  # every 4th frame at stride 4
def make(name, frame_rows, correction):
    shutil.rmtree(name, ignore_errors=True)
    os.makedirs(name)
    shutil.copy('log/sensor.json', name)
    open(f'{name}/frames.csv', 'w').write('\n'.join([header] + frame_rows) + '\n')
    if correction:
        os.makedirs(f'{name}/corrections')
        open(f'{name}/corrections/{stamp}.txt', 'w').write('\n'.join(correction) + '\n')
make('log_thin', rows, thin)
make('log_nocorr', rows, None)
make('log_truth', [','.join(r.split(',')[:2] + g.split()[1:]) for r, g in zip(rows, gt)], None)
open('thin_traj.txt', 'w').write('\n'.join(thin) + '\n')
print(f'{n} frames, {len(thin)} corrected poses')
PY
# Two maps' exact companions equal bit for bit, apart from OpenVDB's file UUID (the first 58
# bytes) and each save's own unit id.
same_exact_state() {
  /usr/bin/python3 - "$1" "$2" "$("$V" info "$1" --json | /usr/bin/python3 -c 'import json,sys; print(json.load(sys.stdin)["unit_id"])')" \
    "$("$V" info "$2" --json | /usr/bin/python3 -c 'import json,sys; print(json.load(sys.stdin)["unit_id"])')" <<'PY'
import sys
from pathlib import Path
a, b, id_a, id_b = sys.argv[1:]
exact = lambda m: Path(m[:-len('.vdb')] + '.exact.vdb').read_bytes()[58:]
sys.exit(0 if exact(a).replace(id_a.encode(), b'ID') == exact(b).replace(id_b.encode(), b'ID') else 1)
PY
}
common="--stride 4 --voxel-size 0.05"
"$V" integrate log_truth $common --mode none -o truth.vdb --mesh truth.ply > /dev/null
for rep in 1 2 3; do
  "$V" integrate log_nocorr $common --mode none -o none.vdb --json none_$rep.json > /dev/null
  "$V" integrate log_thin $common --mode all -o all.vdb --json all_$rep.json > /dev/null
  "$V" integrate log_thin $common --mode keyframes -o kf.vdb --json kf_$rep.json > /dev/null
  "$V" integrate log_nocorr $common --mode all -o off.vdb --json off_$rep.json > /dev/null
  "$V" reintegrate off.vdb --trajectory thin_traj.txt -o off_fixed.vdb --overwrite | tee reintegrate_$rep.txt
done
for m in none all kf off_fixed; do echo "$m: $("$V" eval $m.vdb --gt truth.ply | grep -i rmse)"; done
same_exact_state all.vdb off_fixed.vdb && echo "offline reintegrate == online all, bit for bit"

# The same as a ROS bag (written by python3-rosbag; stamps offset by 1000 s, as bags cannot hold
# time 0): 16UC1 depth, CameraInfo, Odometry, the correction as a nav_msgs/Path.
/usr/bin/python3 "$root/tests/io/make_test_bag.py" log_thin run.bag --stride 4 --time-offset 1000
awk '{printf "%.6f", $1 + 1000; for (i = 2; i <= NF; ++i) printf " %s", $i; print ""}' thin_traj.txt > thin_traj_bag.txt
"$V" info run.bag
for rep in 1 2 3; do
  "$V" integrate run.bag --voxel-size 0.05 --mode none --corrections-topic - -o bnone.vdb --json bnone_$rep.json > /dev/null 2>&1
  "$V" integrate run.bag --voxel-size 0.05 --mode all -o ball.vdb --json ball_$rep.json > /dev/null 2>&1
  "$V" integrate run.bag --voxel-size 0.05 --mode keyframes -o bkf.vdb --json bkf_$rep.json > /dev/null 2>&1
  "$V" integrate run.bag --voxel-size 0.05 --mode all --corrections-topic - -o boff.vdb > /dev/null 2>&1
  "$V" reintegrate boff.vdb --trajectory thin_traj_bag.txt -o boff_fixed.vdb --overwrite | tee breintegrate_$rep.txt
done
for m in bnone ball bkf boff_fixed; do echo "bag $m: $("$V" eval $m.vdb --gt truth.ply | grep -i rmse)"; done
same_exact_state ball.vdb boff_fixed.vdb && echo "bag: offline reintegrate == online all, bit for bit"
