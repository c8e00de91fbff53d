#!/bin/bash
# The package as a user takes it in, built and run on the bundled pair (examples/consumer):
#   scripts/check-package.sh installed [BUILD_DIR]   cmake --install BUILD_DIR (default build/release)
#       into a temporary prefix, then the consumer with find_package(mctstereo), the consumer compiled
#       by hand with `pkg-config --cflags --libs mctstereo`, and the Python module imported from
#       the prefix when it was built (ctest runs this as package.installed);
#   scripts/check-package.sh subdirectory [CMAKE_ARGS...]   the consumer with add_subdirectory() of
#       this source tree, configured with CMAKE_ARGS (-DBUILD_SHARED_LIBS=ON, say): the library alone,
#       no program, tests or benchmarks (CI runs this with a shared library, so that the consumer
#       links only what the shared library exports).
set -euo pipefail
source_dir="$(cd "$(dirname "$0")/.." && pwd)"
mode="${1:-installed}"
work="$(mktemp -d "${TMPDIR:-/tmp}/mctstereo-package.XXXXXX")"
trap 'rm -rf "$work"' EXIT
pair=("$source_dir/data/tsukuba/imL.ppm" "$source_dir/data/tsukuba/imR.ppm")
generator=()
if command -v ninja >/dev/null; then generator=(-G Ninja); fi

case "$mode" in
  installed)
    build="$(cd "${2:-$source_dir/build/release}" && pwd)"
    prefix="$work/prefix"
    cmake --install "$build" --prefix "$prefix" >/dev/null
    echo "== installed tree ($prefix)"
    (cd "$prefix" && find . -type f -o -type l | sort)

    echo "== find_package(mctstereo)"
    cmake -S "$source_dir/examples/consumer" -B "$work/find" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$prefix" | grep -E "^-- mctstereo"
    cmake --build "$work/find" >/dev/null
    found="$("$work/find/consumer" "${pair[@]}")"
    echo "$found"

    echo "== pkg-config"
    export PKG_CONFIG_PATH="$prefix/lib/pkgconfig${PKG_CONFIG_PATH:+:$PKG_CONFIG_PATH}"
    flags="$(pkg-config --cflags --libs mctstereo)"
    echo "pkg-config --cflags --libs mctstereo: $flags"
    echo "pkg-config --modversion mctstereo: $(pkg-config --modversion mctstereo)"
    # shellcheck disable=SC2086
    c++ -std=c++17 -O2 "$source_dir/examples/consumer/main.cpp" -o "$work/pc-consumer" $flags
    by_pkg_config="$(LD_LIBRARY_PATH="$prefix/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" "$work/pc-consumer" "${pair[@]}")"
    echo "$by_pkg_config"
    [ "$(echo "$found" | tail -1 | sed 's/, frame.*//')" = "$(echo "$by_pkg_config" | tail -1 | sed 's/, frame.*//')" ]

    python_dir="$(sed -n 's/^MCTSTEREO_PYTHON_INSTALL_DIR:[A-Z]*=//p' "$build/CMakeCache.txt")"
    python="$(sed -n 's/^Python3_EXECUTABLE:[A-Z]*=//p' "$build/CMakeCache.txt")"
    if [ -n "$python_dir" ] && [ -d "$prefix/$python_dir/mctstereo" ]; then
      echo "== Python module ($python_dir)"
      (cd "$work" && PYTHONPATH="$prefix/$python_dir" "$python" - "${pair[@]}" <<'PY'
import re
import sys
import numpy as np
import mctstereo

def read_ppm(path):
    data = open(path, "rb").read()
    header = re.match(rb"P6\s+(\d+)\s+(\d+)\s+255\s", data)
    w, h = int(header[1]), int(header[2])
    return np.frombuffer(data, np.uint8, w * h * 3, header.end()).reshape(h, w, 3)

left, right = read_ppm(sys.argv[1]), read_ppm(sys.argv[2])
matcher = mctstereo.Matcher(left.shape[1], left.shape[0], mctstereo.preset("balanced", num_disparities=16))
d = matcher.compute(left, right, channels="rgb")
print(f"{mctstereo.__file__}: valid {100 * np.isfinite(d).mean():.2f} %, median disparity {np.nanmedian(d):.4g} px")
PY
      )
      # The batch module is installed with the package (its tests run in the build tree).
      (cd "$work" && PYTHONPATH="$prefix/$python_dir" "$python" -m mctstereo.batch --help >/dev/null && echo "python3 -m mctstereo.batch --help: ok")
    fi
    ;;
  subdirectory)
    echo "== add_subdirectory(mctstereo)"
    shift
    cmake -S "$source_dir/examples/consumer" -B "$work/sub" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
      -DMCTSTEREO_SOURCE_DIR="$source_dir" "$@" >/dev/null
    cmake --build "$work/sub" >/dev/null
    # Only the library and the consumer: nothing of the program, the tests or the benchmarks.
    for target in mctstereo_cli mctstereo_tests mctstereo_benchmarks mctstereo_python; do
      if cmake --build "$work/sub" --target help | grep -qE "(^|\.\.\. )$target(:| |$)"; then
        echo "add_subdirectory built $target" >&2
        exit 1
      fi
    done
    if [ -e "$work/sub/mctstereo/src/libmctstereo.so" ]; then echo "(shared library)"; fi
    "$work/sub/consumer" "${pair[@]}"
    ;;
  *)
    echo "usage: $0 installed [BUILD_DIR] | subdirectory" >&2
    exit 2
    ;;
esac
