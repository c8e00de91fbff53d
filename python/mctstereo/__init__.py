"""mctstereo: dense stereo matching on the (modified) census transform, coarse to fine.

    import mctstereo
    matcher = mctstereo.Matcher(width, height, mctstereo.preset("balanced", num_disparities=64))
    disparity = matcher.compute(left, right)   # numpy uint8 H x W or H x W x 3 (BGR); float32, NaN invalid
    q4 = matcher.disparity_q4()                # int16, 16 x d, matcher.invalid_q4 where invalid
    confidence = matcher.confidence()          # float32 in [0, 1], None for box aggregation

Images are read in place when their pixels are packed within a row (any row stride: OpenCV images
and their ROIs); other layouts are copied once. compute() releases the GIL; a matcher used by
several threads serialises its frames, matchers of their own run in parallel.
"""

import os as _os

# OpenMP (libgomp) threads spin up to 300,000 times at every barrier before they sleep; on a CPU
# shared with other work that spinning takes the time slices of the thread they wait for (2
# threads became 15 times slower than 1 under load). libgomp reads its settings once, when the
# extension loads it: a short spin, unless the user chose a setting of their own.
if "GOMP_SPINCOUNT" not in _os.environ and "OMP_WAIT_POLICY" not in _os.environ:
    _os.environ["GOMP_SPINCOUNT"] = "10000"

from ._mctstereo import (  # noqa: F401,E402
    Aggregation,
    CensusKind,
    FillMode,
    Matcher,
    MeanKernel,
    PointCloud,
    StereoGeometry,
    StereoParams,
    __version__,
    decode_pfm,
    depth_from_disparity,
    encode_pfm,
    estimate_memory,
    geometry_from_projections,
    geometry_from_reprojection,
    have_opencl,
    opencl_devices,
    point_cloud_from_disparity,
    preset,
    preset_description,
    preset_names,
    projection_matrices,
    read_pfm,
    read_ply,
    relative_depth_from_disparity,
    reprojection_matrix,
    version,
    write_pfm,
)

__all__ = [
    "Aggregation",
    "CensusKind",
    "FillMode",
    "Matcher",
    "MeanKernel",
    "PointCloud",
    "StereoGeometry",
    "StereoParams",
    "decode_pfm",
    "depth_from_disparity",
    "encode_pfm",
    "estimate_memory",
    "geometry_from_projections",
    "geometry_from_reprojection",
    "have_opencl",
    "opencl_devices",
    "point_cloud_from_disparity",
    "preset",
    "preset_description",
    "preset_names",
    "projection_matrices",
    "read_pfm",
    "read_ply",
    "relative_depth_from_disparity",
    "reprojection_matrix",
    "version",
    "write_pfm",
]
