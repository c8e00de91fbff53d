# The geometry of a calibration file as the batch reads it (mctstereo.calibration): Middlebury
# calib.txt, OpenCV files with P1/P2 or Q, and the files it refuses.
import numpy as np
import pytest

from mctstereo.calibration import read_geometry

cv2 = pytest.importorskip("cv2")


def write_opencv(path, **matrices):
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for key, value in matrices.items():
        if isinstance(value, str):
            storage.write(key, value)
        elif isinstance(value, (int, float)):
            storage.write(key, value)
        else:
            storage.write(key, np.asarray(value, np.float64))
    storage.release()


def test_middlebury_calib_txt(tmp_path):
    (tmp_path / "calib.txt").write_text("cam0=[3997.684 0 1176.728; 0 3997.684 1011.728; 0 0 1]\n"
                                        "cam1=[3997.684 0 1307.839; 0 3997.684 1011.728; 0 0 1]\n"
                                        "baseline=193.001\nwidth=2964\nheight=1988\nndisp=280\n")
    g = read_geometry(str(tmp_path / "calib.txt"), 2964, 1988)
    assert (g.focal, g.cx, g.cy, g.baseline, g.units) == (3997.684, 1176.728, 1011.728, 193.001, "mm")
    assert g.doffs == pytest.approx(131.111)
    with pytest.raises(ValueError, match="for 2964x1988 images, the pair is 100x100"):
        read_geometry(str(tmp_path / "calib.txt"), 100, 100)


def test_opencv_p1_p2_and_q(tmp_path):
    f, cx, cy, b, doffs = 700.0, 320.5, 240.5, 0.12, 3.0
    p1 = [[f, 0, cx, 0], [0, f, cy, 0], [0, 0, 1, 0]]
    p2 = [[f, 0, cx + doffs, -f * b], [0, f, cy, 0], [0, 0, 1, 0]]
    q = [[1, 0, 0, -cx], [0, 1, 0, -cy], [0, 0, 0, f], [0, 0, 1 / b, doffs / b]]
    write_opencv(tmp_path / "p.yml", P1=p1, P2=p2, units="m")
    write_opencv(tmp_path / "q.yml", Q=q)
    for name in ("p.yml", "q.yml"):
        g = read_geometry(str(tmp_path / name), 640, 480)
        assert (g.focal, g.cx, g.cy, g.units) == (f, cx, cy, "m")
        assert g.baseline == pytest.approx(b) and g.doffs == pytest.approx(doffs)


def test_raw_cameras_and_unknown_files_are_refused(tmp_path):
    k = [[700, 0, 320, 0], [0, 700, 240, 0], [0, 0, 1, 0]]
    write_opencv(tmp_path / "raw.yml", M1=np.eye(3), D1=np.zeros(5), M2=np.eye(3), D2=np.zeros(5), P1=k, P2=k)
    with pytest.raises(ValueError, match="raw cameras"):
        read_geometry(str(tmp_path / "raw.yml"), 640, 480)
    (tmp_path / "notes.txt").write_text("hello\n")
    with pytest.raises(ValueError, match="notes.txt"):
        read_geometry(str(tmp_path / "notes.txt"), 640, 480)
