#!/usr/bin/env bash
# Sets up (Debian packages, Release build into build/), builds everything and runs every test:
# the C++ tests through CTest, then the Python tests through pytest. See README.md.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
vdbmap_install_packages
vdbmap_build_targets
cd "$vdbmap_build"
ctest --output-on-failure -j "$vdbmap_jobs" "$@"
if [ -d "$vdbmap_root/tests/python" ] && ls "$vdbmap_root"/tests/python/test_*.py > /dev/null 2>&1; then
  cd "$vdbmap_root"
  PYTHONPATH="$vdbmap_build/lib${PYTHONPATH:+:$PYTHONPATH}" /usr/bin/python3 -m pytest -q tests/python
fi
