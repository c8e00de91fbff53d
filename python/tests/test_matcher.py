# The Matcher over numpy arrays: the same map as the program, the layouts it reads in place and those
# it copies, and clear errors for what it cannot take.
import numpy as np
import pytest

import mctstereo
from conftest import TSUKUBA, read_pfm, run_cli


def balanced16():
    return mctstereo.preset("balanced", num_disparities=16)


def test_map_of_the_bundled_pair_equals_the_programs_byte_for_byte(tsukuba, cli, tmp_path):
    # `mctstereo match` with its defaults (balanced preset, cpu backend) and the README's range.
    run_cli(cli, "match", TSUKUBA / "imL.png", TSUKUBA / "imR.png", "--num-disparities", 16, "-o", tmp_path / "cli.pfm")
    expected = read_pfm(tmp_path / "cli.pfm")  # +INF where invalid
    left, right = tsukuba
    matcher = mctstereo.Matcher(left.shape[1], left.shape[0], balanced16())
    disparity = matcher.compute(left, right, channels="rgb")
    assert disparity.dtype == np.float32 and disparity.shape == (288, 384)
    assert matcher.copied_inputs == 0
    invalid = np.isnan(disparity)
    np.testing.assert_array_equal(invalid, np.isinf(expected))
    # Byte for byte where valid (the program writes +INF where the library has NaN).
    assert disparity[~invalid].tobytes() == expected[~invalid].tobytes()
    assert 0.8 < (~invalid).mean() <= 1.0
    q4 = matcher.disparity_q4()
    assert q4.dtype == np.int16
    np.testing.assert_array_equal(q4 == matcher.invalid_q4, invalid)
    np.testing.assert_array_equal(q4[~invalid], (expected[~invalid] * 16).astype(np.int16))
    # The same pair in OpenCV's channel order (a reversed channel axis: a view the engine cannot
    # read, so copied) gives the same map.
    bgr = matcher.compute(left[:, :, ::-1], right[:, :, ::-1])
    assert matcher.copied_inputs == 2
    np.testing.assert_array_equal(bgr, disparity)


def test_bundled_ppm_copies_hold_the_pngs_pixels(cli, tmp_path):
    run_cli(cli, "match", TSUKUBA / "imL.png", TSUKUBA / "imR.png", "--num-disparities", 16, "-o", tmp_path / "png.pfm")
    run_cli(cli, "match", TSUKUBA / "imL.ppm", TSUKUBA / "imR.ppm", "--num-disparities", 16, "-o", tmp_path / "ppm.pfm")
    assert (tmp_path / "png.pfm").read_bytes() == (tmp_path / "ppm.pfm").read_bytes()


def test_confidence_and_right_map(tsukuba):
    left, right = tsukuba
    matcher = mctstereo.Matcher(384, 288, balanced16(), compute_right=True)
    matcher.compute(left, right, channels="rgb")
    confidence = matcher.confidence()
    assert confidence.dtype == np.float32 and confidence.shape == (288, 384)
    assert 0.0 <= confidence.min() and confidence.max() <= 1.0
    assert matcher.right_disparity_q4().shape == (288, 384)
    box = mctstereo.Matcher(384, 288, mctstereo.preset("realtime", num_disparities=16))
    with pytest.raises(RuntimeError, match="compute"):
        box.disparity()
    box.compute(left, right)
    assert box.confidence() is None
    assert box.right_disparity_q4() is None
    assert set(box.timings) >= {"census", "match", "frame"}
    # A box preset gives its confidence when asked, and the same map as without it.
    confident_box = mctstereo.Matcher(384, 288, mctstereo.preset("realtime", num_disparities=16),
                                      compute_confidence=True)
    confident_box.compute(left, right)
    box_confidence = confident_box.confidence()
    assert box_confidence.shape == (288, 384)
    assert 0.0 <= box_confidence.min() and box_confidence.max() <= 1.0
    assert np.mean(box_confidence > 0.25) > 1 / 3
    assert not np.array_equal(box_confidence, confidence)
    assert np.array_equal(confident_box.disparity_q4(), box.disparity_q4())


def test_gray_and_colour_in_place_layouts(tsukuba):
    left, right = tsukuba
    gray_l = np.ascontiguousarray(left[:, :, 1])
    gray_r = np.ascontiguousarray(right[:, :, 1])
    matcher = mctstereo.Matcher(384, 288, balanced16())
    expected = matcher.compute(gray_l, gray_r)
    assert matcher.copied_inputs == 0
    # H x W x 1 is gray too.
    np.testing.assert_array_equal(matcher.compute(gray_l[:, :, None], gray_r[:, :, None]), expected)
    assert matcher.copied_inputs == 0
    # A region of a larger image (OpenCV ROI): row stride wider than a row, read in place.
    big_l = np.zeros((300, 400), np.uint8)
    big_r = np.zeros((300, 400), np.uint8)
    big_l[5:293, 7:391] = gray_l
    big_r[5:293, 7:391] = gray_r
    roi = matcher.compute(big_l[5:293, 7:391], big_r[5:293, 7:391])
    assert matcher.copied_inputs == 0
    np.testing.assert_array_equal(roi, expected)
    # Colour ROI.
    big = np.zeros((300, 400, 3), np.uint8)
    big[5:293, 7:391] = left
    colour = mctstereo.Matcher(384, 288, balanced16())
    reference = colour.compute(left, right, channels="rgb")
    np.testing.assert_array_equal(colour.compute(big[5:293, 7:391], right, channels="rgb"), reference)
    assert colour.copied_inputs == 0
    # Read-only arrays are fine.
    ro_l, ro_r = left.copy(), right.copy()
    ro_l.flags.writeable = False
    ro_r.flags.writeable = False
    np.testing.assert_array_equal(colour.compute(ro_l, ro_r, channels="rgb"), reference)


@pytest.mark.parametrize("layout", ["column_step", "flipped_twice", "fortran", "channels_first"])
def test_layouts_the_engine_cannot_read_are_copied(tsukuba, layout):
    left, right = tsukuba
    matcher = mctstereo.Matcher(384, 288, balanced16())
    reference = matcher.compute(left, right, channels="rgb")

    def view(image):
        if layout == "column_step":  # every other column of a double-width image
            wide = np.repeat(image, 2, axis=1)
            return wide[:, ::2]
        if layout == "flipped_twice":  # negative strides
            return np.flip(np.ascontiguousarray(np.flip(image, (0, 1))), (0, 1))
        if layout == "fortran":
            return np.asfortranarray(image)
        return np.ascontiguousarray(image.transpose(2, 0, 1)).transpose(1, 2, 0)  # planes behind an H x W x 3 view

    l, r = view(left), view(right)
    assert not l.flags.c_contiguous
    np.testing.assert_array_equal(matcher.compute(l, r, channels="rgb"), reference)
    assert matcher.copied_inputs == 2


def test_clear_errors(tsukuba):
    left, right = tsukuba
    matcher = mctstereo.Matcher(384, 288, balanced16())
    with pytest.raises(TypeError, match="left image: dtype float32, expected uint8"):
        matcher.compute(left.astype(np.float32), right)
    with pytest.raises(TypeError, match="right image: dtype uint16"):
        matcher.compute(left, right.astype(np.uint16))
    with pytest.raises(TypeError, match="dtype int64"):
        matcher.compute([[1, 2], [3, 4]], right)
    with pytest.raises(ValueError, match=r"shape \(288, 384, 4\).*alpha"):
        matcher.compute(np.zeros((288, 384, 4), np.uint8), right)
    with pytest.raises(ValueError, match=r"left image: shape \(288, 384, 2\), expected H x W \(gray\) or H x W x 3"):
        matcher.compute(np.zeros((288, 384, 2), np.uint8), right)
    with pytest.raises(ValueError, match=r"shape \(110592,\)"):
        matcher.compute(left[:, :, 0].ravel(), right)
    with pytest.raises(ValueError, match="right image is 380 x 288 .*the matcher's size is 384 x 288"):
        matcher.compute(left, right[:, :380])
    with pytest.raises(ValueError, match="channels"):
        matcher.compute(left, right, channels="bgra")
    with pytest.raises(ValueError, match="reference, cpu, opencl"):
        mctstereo.Matcher(384, 288, balanced16(), backend="gpu")
    # A matcher that failed keeps working.
    assert matcher.compute(left, right).shape == (288, 384)


def test_matcher_rejects_invalid_parameters_with_the_librarys_message():
    params = mctstereo.preset("balanced")
    params.census_window = 4
    with pytest.raises(ValueError, match="census_window = 4 must be 3, 5, 7 or 9"):
        mctstereo.Matcher(384, 288, params)
    with pytest.raises(ValueError, match="wider than the image"):
        mctstereo.Matcher(32, 32, mctstereo.preset("balanced", num_disparities=64))


def test_backends_agree(tsukuba):
    left, right = tsukuba
    small_l, small_r = np.ascontiguousarray(left[:96, :128]), np.ascontiguousarray(right[:96, :128])
    maps = {}
    for backend in ["reference", "cpu"]:
        m = mctstereo.Matcher(128, 96, balanced16(), backend=backend, threads=1)
        assert m.backend == backend
        maps[backend] = m.compute(small_l, small_r, channels="rgb")
    np.testing.assert_array_equal(maps["reference"], maps["cpu"])


def test_temporal_prior_over_a_sequence(tsukuba):
    left, right = tsukuba
    params = mctstereo.preset("quality", num_disparities=16, temporal=True)
    seq = mctstereo.Matcher(384, 288, params)
    alone = mctstereo.Matcher(384, 288, mctstereo.preset("quality", num_disparities=16))
    first = seq.compute(left, right, channels="rgb")
    assert not seq.used_temporal_prior
    np.testing.assert_array_equal(first, alone.compute(left, right, channels="rgb"))
    second = seq.compute(left, right, channels="rgb")
    assert seq.used_temporal_prior
    # The same frame again: the prior narrows the search around the first map, which a few pixels
    # leave (about 1.3 %), and the map stays whole.
    valid = ~np.isnan(first) & ~np.isnan(second)
    assert np.mean(valid) > 0.99
    changed = np.mean(np.abs(first[valid] - second[valid]) > 1)
    assert 0.0 < changed < 0.03
    seq.reset_temporal()
    np.testing.assert_array_equal(seq.compute(left, right, channels="rgb"), first)
    assert not seq.used_temporal_prior
    with pytest.raises(ValueError, match="temporal_radius"):
        mctstereo.Matcher(384, 288, mctstereo.preset("quality", temporal=True, temporal_radius=17))


def test_sgm_in_segments_gives_the_same_maps_in_less_memory(tsukuba):
    # sgm_volume_limit=0 aggregates every band SGM level in segments of rows: the maps of the whole
    # volume, from less memory.
    left, right = tsukuba
    params = mctstereo.preset("quality", num_disparities=32)
    whole = mctstereo.Matcher(384, 288, params, threads=2, compute_right=True, sgm_volume_limit=2**62)
    segments = mctstereo.Matcher(384, 288, params, threads=2, compute_right=True, sgm_volume_limit=0)
    whole.compute(left, right, channels="rgb")
    segments.compute(left, right, channels="rgb")
    np.testing.assert_array_equal(segments.disparity_q4(), whole.disparity_q4())
    np.testing.assert_array_equal(segments.right_disparity_q4(), whole.right_disparity_q4())
    np.testing.assert_array_equal(segments.confidence(), whole.confidence())
    assert (mctstereo.estimate_memory(params, 384, 288, sgm_volume_limit=0) <
            mctstereo.estimate_memory(params, 384, 288, sgm_volume_limit=2**62))
