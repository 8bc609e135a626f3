# Shared set-up for demo.sh and test.sh: Debian packages, configure, build. Sourced, not run.
# A second run installs nothing and rebuilds only what changed.

# Every Debian 12 package the project needs to build, test and run its demo.
VDBMAP_APT_PACKAGES=(
  build-essential cmake ninja-build pkg-config
  libopenvdb-dev libopenvdb-tools libtbb-dev libeigen3-dev libblosc-dev zlib1g-dev
  libboost-iostreams-dev libboost-serialization-dev libboost-filesystem-dev libboost-system-dev
  libompl-dev libceres-dev libpng-dev libdeflate-dev libcli11-dev nlohmann-json3-dev libnanoflann-dev
  catch2 pybind11-dev python3-dev python3-numpy python3-pytest python3-openvdb
  librosbag-storage-dev libsensor-msgs-dev libnav-msgs-dev libgeometry-msgs-dev
)
# And for the tests only: the report's browser test (headless Chromium, WebGL through SwiftShader;
# Pillow reads its screenshots; a font for the page's text).
# And test ROS bags written by ROS's own Python library.
VDBMAP_TEST_APT_PACKAGES=(chromium python3-pil fonts-dejavu-core
  python3-rosbag python3-sensor-msgs python3-nav-msgs python3-geometry-msgs)

vdbmap_root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
vdbmap_build="${VDBMAP_BUILD_DIR:-$vdbmap_root/build}"
# Each OpenVDB compile job peaks near 1 GB; never more than 4 jobs.
vdbmap_jobs="${VDBMAP_JOBS:-$(nproc 2>/dev/null || echo 2)}"
[ "$vdbmap_jobs" -gt 4 ] && vdbmap_jobs=4

# vdbmap_install_packages [extra package...]: installs what is missing of VDBMAP_APT_PACKAGES and the extras.
vdbmap_install_packages() {
  local missing=()
  for p in "${VDBMAP_APT_PACKAGES[@]}" "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  if [ "$(id -u)" -ne 0 ]; then
    echo "Missing Debian packages. Install them with:" >&2
    echo "  sudo apt-get update && sudo apt-get install -y ${missing[*]}" >&2
    exit 1
  fi
  echo "== installing ${#missing[@]} Debian packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

# The build's CMake options. The Python module is on: scripts/test.sh runs its tests.
VDBMAP_CMAKE_OPTIONS=(
  -DCMAKE_BUILD_TYPE=Release -DVDBMAP_BUILD_TESTS=ON -DVDBMAP_BUILD_PYTHON=ON -DVDBMAP_BUILD_BENCHMARKS=ON
  -DPython_EXECUTABLE=/usr/bin/python3
)

# True when the build dir has no cache yet or a cached option differs from VDBMAP_CMAKE_OPTIONS
# (e.g. a build dir made before an option changed): a grep, no CMake run.
vdbmap_configure_needed() {
  local cache="$vdbmap_build/CMakeCache.txt" opt name value
  [ -f "$cache" ] || return 0
  for opt in "${VDBMAP_CMAKE_OPTIONS[@]}"; do
    name=${opt#-D}; value=${name#*=}; name=${name%%=*}
    # Cache lines read NAME:TYPE=VALUE.
    awk -v n="$name" -v v="$value" 'index($0, n ":") == 1 && substr($0, index($0, "=") + 1) == v { found = 1 }
                                    END { exit !found }' "$cache" || return 0
  done
  return 1
}

# vdbmap_build_targets [target...]: configure (Release, Ninja) when needed, then build what is asked.
vdbmap_build_targets() {
  if vdbmap_configure_needed; then
    local generator=(-G Ninja)
    [ -f "$vdbmap_build/CMakeCache.txt" ] && generator=()  # an existing build dir keeps its generator
    cmake -S "$vdbmap_root" -B "$vdbmap_build" "${generator[@]}" "${VDBMAP_CMAKE_OPTIONS[@]}" \
      > "$vdbmap_build.configure.log" 2>&1 ||
      { cat "$vdbmap_build.configure.log"; rm -f "$vdbmap_build/CMakeCache.txt"; exit 1; }
  fi
  if [ $# -eq 0 ]; then
    cmake --build "$vdbmap_build" -j "$vdbmap_jobs"
  else
    cmake --build "$vdbmap_build" -j "$vdbmap_jobs" --target "$@"
  fi
}
