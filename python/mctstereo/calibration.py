"""The geometry of a rectified pair from a calibration file, as `mctstereo match --calib` reads it:
a Middlebury calib.txt (cam0=[f 0 cx; 0 f cy; 0 0 1], baseline in mm, doffs or cam1) or an OpenCV
FileStorage file (.yml, .yaml, .xml, .json) with P1 and P2 or Q, in metres unless it has a
"units" string. A file of the raw cameras (K1 D1 K2 D2, or M1 D1 M2 D2, without `rectified: 1`)
is for images that must be rectified first, which only the program does: ValueError here.
"""

import re

from ._mctstereo import StereoGeometry, geometry_from_projections, geometry_from_reprojection


def _middlebury_values(text):
    values = {}
    for number, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        if "=" not in line:
            raise ValueError(f"line {number} is not 'key=value': '{line}'")
        key, value = line.split("=", 1)
        values[key.strip()] = value.strip()
    return values


def _middlebury_matrix(key, text):
    rows = [r.split() for r in text.strip().strip("[]").split(";")]
    if len(rows) != 3 or any(len(r) != 3 for r in rows):
        raise ValueError(f"key '{key}' is not a 3x3 matrix [a b c; d e f; g h i]: '{text}'")
    return [[float(v) for v in r] for r in rows]


def _read_middlebury(text, width, height):
    values = _middlebury_values(text)
    for key in ("cam0", "baseline"):
        if key not in values:
            raise ValueError(f"key '{key}' is missing")
    cam0 = _middlebury_matrix("cam0", values["cam0"])
    if "doffs" in values:
        doffs = float(values["doffs"])
    elif "cam1" in values:
        doffs = _middlebury_matrix("cam1", values["cam1"])[0][2] - cam0[0][2]
    else:
        raise ValueError("key 'doffs' is missing (or 'cam1' to compute it from)")
    size = (int(float(values.get("width", 0))), int(float(values.get("height", 0))))
    _check_size(size, width, height)
    return StereoGeometry(cam0[0][0], float(values["baseline"]), cam0[0][2], cam0[1][2], doffs, "mm")


def _check_size(size, width, height):
    if size[0] and size[1] and (size[0], size[1]) != (width, height):
        raise ValueError(f"the calibration is for {size[0]}x{size[1]} images, the pair is {width}x{height}")


def _read_opencv(path, width, height):
    import cv2

    try:
        storage = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError):  # OpenCV's parser raises on what is not YAML, XML or JSON
        storage = None
    if storage is None or not storage.isOpened():
        raise ValueError("unknown format: expected a Middlebury calib.txt or an OpenCV YAML, XML or JSON file")

    def matrix(key):
        node = storage.getNode(key)
        return None if node.empty() else node.mat()

    def number(*keys):
        for key in keys:
            node = storage.getNode(key)
            if not node.empty():
                return node.real()
        return 0

    raw = all(matrix(k) is not None for k in ("D1", "D2")) and any(matrix(k) is not None for k in ("K1", "M1"))
    if raw and int(number("rectified")) != 1:
        raise ValueError("it holds the raw cameras (K1 D1 K2 D2): the pair must be rectified first "
                         "(mctstereo match --calib rectifies; or give a file of the rectified pair)")
    _check_size((int(number("image_width", "width")), int(number("image_height", "height"))), width, height)
    units_node = storage.getNode("units")
    units = units_node.string() if not units_node.empty() else "m"
    p1, p2, q = matrix("P1"), matrix("P2"), matrix("Q")
    if p1 is not None and p2 is not None:
        return geometry_from_projections(p1, p2, units)
    if q is not None:
        return geometry_from_reprojection(q, units)
    raise ValueError("keys 'P1' and 'P2' (or 'Q') are missing")


def read_geometry(path, width, height):
    """The StereoGeometry of a rectified width x height pair from a calibration file; ValueError
    naming the file and what is wrong."""
    try:
        with open(path, "rb") as f:
            text = f.read().decode("utf-8", "replace")
        if re.search(r"^\s*(cam0|cam1|baseline|doffs)\s*=", text, re.MULTILINE):
            geometry = _read_middlebury(text, width, height)
        else:
            geometry = _read_opencv(path, width, height)
        geometry.validate()
        return geometry
    except (ValueError, OSError) as e:
        raise ValueError(f"calibration '{path}': {e}") from None
