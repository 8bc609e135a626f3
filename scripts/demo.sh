#!/usr/bin/env bash
# Sets up (Debian packages, Release build into build/) and runs the main job. See README.md.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
vdbmap_install_packages
vdbmap_build_targets vdbmap_cli
cd "$vdbmap_root"
mkdir -p demo_out
"$vdbmap_build/bin/vdbmap" demo -o demo_out "$@"
