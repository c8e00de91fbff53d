#!/bin/sh
# Installs what mctstereo needs to build, run and test on Debian 12 (run as root, or with sudo):
# OpenCL's headers and ICD loader build the opencl backend; PoCL is an OpenCL driver for the CPU,
# so that the opencl backend runs (and is tested) without a GPU; clinfo lists the devices; pybind11,
# Python's headers and numpy build the Python module, pytest tests it; OpenCV's Python module reads
# the images of batches, Dask and its distributed scheduler run them (python3 -m mctstereo.batch).
#
# Options add what the hardening checks of CI need (docs/RELIABILITY.md), on top of the above:
#   --sanitizers  clang-14, libFuzzer and LLVM's OpenMP runtime (with its ThreadSanitizer tool
#                 Archer): the presets fuzz and tsan
#   --arm64       Debian's arm64 architecture, the aarch64 cross compiler, Highway and GoogleTest
#                 for arm64, and qemu-user: the preset aarch64
set -eu
sanitizers=0
arm64=0
for option in "$@"; do
  case "$option" in
    --sanitizers) sanitizers=1 ;;
    --arm64) arm64=1 ;;
    *) echo "install-deps.sh: unknown option '$option' (known: --sanitizers, --arm64)" >&2; exit 2 ;;
  esac
done
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
if [ "$arm64" = 1 ]; then $SUDO dpkg --add-architecture arm64; fi
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends \
  g++ cmake ninja-build pkg-config \
  libhwy-dev libopencv-dev libcli11-dev libgtest-dev libbenchmark-dev \
  ocl-icd-opencl-dev opencl-clhpp-headers opencl-c-headers pocl-opencl-icd clinfo \
  python3 python3-dev python3-numpy python3-pytest pybind11-dev python3-pybind11 \
  python3-opencv python3-dask python3-distributed >/dev/null
if [ "$sanitizers" = 1 ]; then
  $SUDO apt-get install -y -qq --no-install-recommends clang-14 libfuzzer-14-dev libomp-14-dev >/dev/null
fi
if [ "$arm64" = 1 ]; then
  $SUDO apt-get install -y -qq --no-install-recommends g++-aarch64-linux-gnu qemu-user-static \
    libhwy-dev:arm64 libgtest-dev:arm64 >/dev/null
fi
