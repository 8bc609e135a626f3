#!/usr/bin/env bash
# Sets up (Debian packages, Release build into build/), builds everything and runs every test:
# the C++ tests through CTest, the Python tests through pytest, then installs into a temporary
# prefix and builds and runs the consumer project (tests/consumer) against the installed package.
# See README.md.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
vdbmap_install_packages "${VDBMAP_TEST_APT_PACKAGES[@]}"
vdbmap_build_targets
cd "$vdbmap_build"
ctest --output-on-failure -j "$vdbmap_jobs" "$@"
if [ -d "$vdbmap_root/tests/python" ] && ls "$vdbmap_root"/tests/python/test_*.py > /dev/null 2>&1; then
  cd "$vdbmap_root"
  PYTHONPATH="$vdbmap_build/lib${PYTHONPATH:+:$PYTHONPATH}" /usr/bin/python3 -m pytest -q tests/python
fi

# The installed package, as a user's project sees it. The prefix is kept between runs so that an
# unchanged tree installs (and the consumer rebuilds) nothing.
echo "== install into $vdbmap_build/install-test and build tests/consumer against it"
prefix="$vdbmap_build/install-test"
cmake --install "$vdbmap_build" --prefix "$prefix" > "$vdbmap_build/install-test.log"
consumer="$vdbmap_build/consumer-test"
cmake -S "$vdbmap_root/tests/consumer" -B "$consumer" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" > "$consumer.configure.log" 2>&1 || { cat "$consumer.configure.log"; exit 1; }
cmake --build "$consumer"
"$consumer/vdbmap_consumer"
# The installed Python module imports from the prefix (not from the build tree).
python_dir=$(sed -n 's/^VDBMAP_PYTHON_INSTALL_DIR:[A-Z]*=//p' "$vdbmap_build/CMakeCache.txt")
(cd / && PYTHONPATH="$prefix/$python_dir" /usr/bin/python3 -c \
  "import vdbmap, sys; assert vdbmap.__file__.startswith(sys.argv[1]), vdbmap.__file__; print('installed Python module', vdbmap.__version__, 'ok')" \
  "$prefix")
