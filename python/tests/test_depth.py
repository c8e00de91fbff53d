# Depth and point clouds from the maps, as numpy arrays.
import math

import numpy as np
import pytest

import mctstereo


@pytest.fixture(scope="module")
def matched(tsukuba):
    left, right = tsukuba
    matcher = mctstereo.Matcher(384, 288, mctstereo.preset("balanced", num_disparities=16))
    disparity = matcher.compute(left, right, channels="rgb")
    return matcher, disparity, left


def test_depth_from_float_and_q4_maps(matched):
    matcher, disparity, _ = matched
    g = mctstereo.StereoGeometry(focal=615.0, baseline=0.1, cx=191.5, cy=143.5)
    g.validate()
    depth = mctstereo.depth_from_disparity(disparity, g)
    assert depth.dtype == np.float32 and depth.shape == disparity.shape
    valid = ~np.isnan(disparity) & (disparity > 0)
    np.testing.assert_allclose(depth[valid], 615.0 * 0.1 / disparity[valid], rtol=1e-6)
    assert np.isnan(depth[~valid]).all()
    from_q4 = mctstereo.depth_from_disparity(matcher.disparity_q4(), g, invalid_q4=matcher.invalid_q4)
    np.testing.assert_array_equal(np.isnan(from_q4), np.isnan(depth))
    np.testing.assert_allclose(from_q4[valid], depth[valid], rtol=1e-6)
    near = mctstereo.depth_from_disparity(disparity, g, max_depth=10.0)
    assert np.nanmax(near) <= 10.0
    assert math.isclose(g.depth(10.0), 6.15)
    with pytest.raises(TypeError, match="invalid_q4"):
        mctstereo.depth_from_disparity(matcher.disparity_q4(), g)
    with pytest.raises(TypeError, match="dtype float64"):
        mctstereo.depth_from_disparity(disparity.astype(np.float64), g)
    with pytest.raises(ValueError, match="focal"):
        mctstereo.StereoGeometry(focal=0.0, baseline=0.1).validate()
    relative = mctstereo.relative_depth_from_disparity(matcher.disparity_q4(), matcher.invalid_q4)
    np.testing.assert_allclose(relative[valid], 1.0 / disparity[valid], rtol=1e-6)


def test_point_cloud(matched, tmp_path):
    matcher, disparity, left = matched
    g = mctstereo.StereoGeometry(focal=615.0, baseline=0.1, cx=191.5, cy=143.5)
    cloud = mctstereo.point_cloud_from_disparity(matcher.disparity_q4(), matcher.invalid_q4, g, left, channels="rgb")
    valid = ~np.isnan(disparity) & (disparity > 0)
    assert len(cloud) == valid.sum()
    assert cloud.xyz.shape == (len(cloud), 3) and cloud.xyz.dtype == np.float32
    assert cloud.rgb.shape == (len(cloud), 3) and cloud.rgb.dtype == np.uint8
    ys, xs = np.divmod(cloud.pixel, 384)
    np.testing.assert_array_equal(cloud.rgb, left[ys, xs])
    np.testing.assert_allclose(cloud.xyz[:, 2], 61.5 / disparity[ys, xs], rtol=1e-5)
    np.testing.assert_allclose(cloud.xyz[:, 0], (xs - 191.5) * cloud.xyz[:, 2] / 615.0, rtol=1e-5, atol=1e-6)
    bare = mctstereo.point_cloud_from_disparity(matcher.disparity_q4(), matcher.invalid_q4, g)
    assert bare.rgb is None and len(bare) == len(cloud)
    cloud.write_ply(str(tmp_path / "c.ply"), ["tsukuba"])
    header = (tmp_path / "c.ply").read_bytes()[:200]
    assert header.startswith(b"ply\nformat binary_little_endian 1.0\n")
    assert b"element vertex %d\n" % len(cloud) in header and b"comment tsukuba" in header
    cloud.write_obj(str(tmp_path / "c.obj"))
    assert (tmp_path / "c.obj").read_text().count("\nv ") + 1 >= len(cloud)
    with pytest.raises(ValueError, match="colours image is 10 x 10"):
        mctstereo.point_cloud_from_disparity(matcher.disparity_q4(), matcher.invalid_q4, g, np.zeros((10, 10), np.uint8))
