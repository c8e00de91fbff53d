# StereoParams: every field, presets, validation errors as ValueError with the library's message.
import copy
import pathlib
import pickle
import re

import pytest

import mctstereo

FIELDS = [
    "min_disparity", "num_disparities", "census", "census_window", "mct_kernel", "shd_window",
    "coarse_shd_window", "pyramid_levels", "search_radius", "subpixel", "median_size", "lr_check",
    "lr_threshold", "lr_check_grid", "speckle_size", "uniqueness_ratio", "fill", "post_median_size", "refine_all_levels",
    "aggregation", "sgm_p1", "sgm_p2", "sgm_p2_k", "prior_size", "box_levels", "finest_search_radius", "sgm_max_band",
    "weighted_median", "wm_radius", "wm_step", "wm_sigma", "working_scale",
    "temporal", "temporal_radius", "temporal_threshold",
]


def test_the_binding_has_every_field_of_the_header():
    # A field added to include/mctstereo/params.hpp needs its line in python/mctstereo_module.cpp.
    header = (pathlib.Path(__file__).resolve().parents[2] / "include" / "mctstereo" / "params.hpp").read_text()
    body = header[header.index("struct StereoParams {"):]
    body = body[:body.index("\n};")]
    declared = re.findall(r"^  (?:int|bool|double|float|CensusKind|MeanKernel|FillMode|Aggregation)\s+(\w+)\s*=", body, re.M)
    assert len(declared) >= 20
    assert sorted(declared) == sorted(mctstereo._mctstereo._PARAM_FIELDS)
    assert sorted(declared) == sorted(FIELDS)


def test_every_field_reads_and_writes():
    p = mctstereo.StereoParams()
    for name in FIELDS:
        assert hasattr(p, name), name
    assert set(FIELDS) <= set(mctstereo.StereoParams().to_dict())
    p.num_disparities = 48
    p.min_disparity = -8
    assert p.max_disparity() == 39
    p.census = "mct"
    assert p.census == mctstereo.CensusKind.MCT and p.census.label == "mct"
    p.fill = mctstereo.FillMode.NEAREST
    p.aggregation = "sgm8"
    assert p.sgm() and p.sgm_paths() == 8
    p.mct_kernel = "mean"
    assert p.mct_kernel == mctstereo.MeanKernel.MEAN
    p.finest_search_radius = -1
    assert p.finest_radius() == p.search_radius
    assert mctstereo.preset("balanced").weighted_median and not mctstereo.preset("realtime").weighted_median
    p.wm_step = 20
    with pytest.raises(ValueError, match="wm_step = 20 must be in"):
        p.validate()
    p.wm_step = 3
    with pytest.raises(ValueError, match="unknown value 'sgm6' .*box, sgm4, sgm8"):
        p.aggregation = mctstereo.Aggregation("sgm6")
    with pytest.raises(TypeError):
        p.aggregation = "sgm6"  # no conversion: pybind11's TypeError


def test_presets():
    names = mctstereo.preset_names()
    assert names[:3] == ["realtime", "balanced", "quality"] or "balanced" in names
    for name in names:
        mctstereo.preset(name).validate()
        assert mctstereo.preset_description(name)
    balanced = mctstereo.preset("balanced", num_disparities=16, speckle_size=10)
    assert balanced.aggregation == mctstereo.Aggregation.SGM4 and balanced.num_disparities == 16
    assert balanced.speckle_size == 10
    with pytest.raises(ValueError, match="unknown preset 'fast' \\(known: realtime"):
        mctstereo.preset("fast")
    with pytest.raises(TypeError, match="no field 'disparities'"):
        mctstereo.preset("balanced", disparities=16)


def test_validate_raises_the_librarys_message():
    p = mctstereo.preset("balanced")
    p.validate()
    assert p.problems() == []
    p.census_window = 4
    p.median_size = 4
    with pytest.raises(ValueError) as e:
        p.validate()
    assert "census_window = 4 must be 3, 5, 7 or 9" in str(e.value)
    assert "median_size = 4 must be 0 (off), 3 or 5" in str(e.value)
    assert len(p.problems()) == 2
    q = mctstereo.preset("balanced", num_disparities=64)
    q.validate()
    with pytest.raises(ValueError, match="num_disparities = 64 is wider than the image \\(40 px\\)"):
        q.validate(40, 30)
    with pytest.raises(TypeError):
        q.validate(40)


def test_keywords_equality_copy_pickle_repr():
    p = mctstereo.StereoParams(num_disparities=32, census="mct", fill="none")
    assert p.num_disparities == 32 and p.fill == mctstereo.FillMode.NONE
    with pytest.raises(TypeError, match="no field 'disparity'"):
        mctstereo.StereoParams(disparity=3)
    assert p == copy.copy(p) == copy.deepcopy(p) == pickle.loads(pickle.dumps(p))
    q = copy.copy(p)
    q.sgm_p1 = 1
    assert q != p and p.sgm_p1 != 1
    text = repr(p)
    assert text.startswith("StereoParams(min_disparity=0, num_disparities=32")
    for name in FIELDS:
        assert name + "=" in text
    assert mctstereo.Matcher(64, 48, p).params == p


def test_version_and_backends():
    assert mctstereo.version() == mctstereo.__version__
    assert mctstereo.version().count(".") == 2
    assert isinstance(mctstereo.have_opencl(), bool)
    assert isinstance(mctstereo.opencl_devices(), list)
    assert mctstereo.estimate_memory(mctstereo.preset("balanced"), 640, 480) > 640 * 480
