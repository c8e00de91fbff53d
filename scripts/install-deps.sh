#!/bin/sh
# Installs what mctstereo needs to build, run and test on Debian 12 (run as root, or with sudo):
# OpenCL's headers and ICD loader build the opencl backend; PoCL is an OpenCL driver for the CPU,
# so that the opencl backend runs (and is tested) without a GPU; clinfo lists the devices; pybind11,
# Python's headers and numpy build the Python module, pytest tests it; OpenCV's Python module reads
# the images of batches, Dask and its distributed scheduler run them (python3 -m mctstereo.batch).
set -eu
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends \
  g++ cmake ninja-build pkg-config \
  libhwy-dev libopencv-dev libcli11-dev libgtest-dev libbenchmark-dev \
  ocl-icd-opencl-dev opencl-clhpp-headers opencl-c-headers pocl-opencl-icd clinfo \
  python3 python3-dev python3-numpy python3-pytest pybind11-dev python3-pybind11 \
  python3-opencv python3-dask python3-distributed >/dev/null
