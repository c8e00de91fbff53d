# The file functions of the library over numpy: PFM as the program writes it, PLY clouds read back,
# and OpenCV's matrices of a geometry.
import numpy as np
import pytest

import mctstereo
from conftest import TSUKUBA, run_cli


def test_pfm_bytes_equal_the_programs(cli, tmp_path):
    run_cli(cli, "match", TSUKUBA / "imL.png", TSUKUBA / "imR.png", "--num-disparities", 16, "-o", tmp_path / "d.pfm")
    disparity = mctstereo.read_pfm(str(tmp_path / "d.pfm"))
    assert disparity.dtype == np.float32 and disparity.shape == (288, 384)
    assert mctstereo.encode_pfm(disparity) == (tmp_path / "d.pfm").read_bytes()
    mctstereo.write_pfm(str(tmp_path / "again.pfm"), disparity)
    assert (tmp_path / "again.pfm").read_bytes() == (tmp_path / "d.pfm").read_bytes()


def test_pfm_round_trip_writes_inf_where_not_finite():
    values = np.array([[1.5, np.nan], [-np.inf, 2.0]], np.float32)
    back = mctstereo.decode_pfm(mctstereo.encode_pfm(values))
    np.testing.assert_array_equal(back, [[1.5, np.inf], [np.inf, 2.0]])
    # Any strides: a transposed view is the transposed map.
    np.testing.assert_array_equal(mctstereo.decode_pfm(mctstereo.encode_pfm(values.T)), back.T)
    with pytest.raises(TypeError, match="float32"):
        mctstereo.encode_pfm(values.astype(np.float64))
    with pytest.raises(RuntimeError, match="truncated PFM"):
        mctstereo.decode_pfm(mctstereo.encode_pfm(values)[:-1])


def test_read_ply_gives_back_the_cloud_written(tmp_path):
    geometry = mctstereo.StereoGeometry(400.0, 0.1, 191.5, 143.5)
    q4 = np.full((4, 5), 16 * 8, np.int16)
    q4[1, 2] = -16
    colours = np.arange(4 * 5 * 3, dtype=np.uint8).reshape(4, 5, 3)
    cloud = mctstereo.point_cloud_from_disparity(q4, -16, geometry, colours, channels="rgb")
    cloud.write_ply(str(tmp_path / "c.ply"), ["a comment"])
    back = mctstereo.read_ply(str(tmp_path / "c.ply"))
    assert len(back) == len(cloud) == 19
    np.testing.assert_array_equal(back.xyz, cloud.xyz)
    np.testing.assert_array_equal(back.rgb, cloud.rgb)
    (tmp_path / "bad.ply").write_text("obj\n")
    with pytest.raises(RuntimeError, match="'.*bad.ply' is not a PLY file"):
        mctstereo.read_ply(str(tmp_path / "bad.ply"))


def test_geometry_from_opencvs_matrices_and_back():
    geometry = mctstereo.StereoGeometry(700.5, 0.12, 320.25, 240.75, 3.5, "m")
    p1, p2 = mctstereo.projection_matrices(geometry)
    q = mctstereo.reprojection_matrix(geometry)
    assert p1.shape == (3, 4) and q.shape == (4, 4)
    assert p2[0, 3] == pytest.approx(-700.5 * 0.12)
    for back in (mctstereo.geometry_from_projections(p1, p2), mctstereo.geometry_from_reprojection(q)):
        assert (back.focal, back.cx, back.cy, back.units) == (700.5, 320.25, 240.75, "m")
        assert back.baseline == pytest.approx(0.12) and back.doffs == pytest.approx(3.5)
    p2[0, 3] = -p2[0, 3]
    with pytest.raises(ValueError, match="P2 gives a baseline"):
        mctstereo.geometry_from_projections(p1, p2)
    with pytest.raises(ValueError, match="Q: expected a 4 x 4 matrix"):
        mctstereo.geometry_from_reprojection(np.eye(3))
