#!/usr/bin/python3
"""Writes the seed corpora of the fuzz targets into fuzz/corpus/<target>/ (committed; rerun only to
change them). Each holds a few small valid inputs and a few invalid ones. Needs numpy and OpenCV's
Python module (python3-opencv) for the images."""
import os
import struct
import sys

import cv2
import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus")


def put(target, name, data):
    folder = os.path.join(ROOT, target)
    os.makedirs(folder, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(folder, name), "wb") as f:
        f.write(data)


def pfm(w, h, values, scale="-1.0", magic="Pf"):
    little = scale.startswith("-")
    body = struct.pack(("<" if little else ">") + "%df" % len(values), *values)
    return ("%s\n%d %d\n%s\n" % (magic, w, h, scale)).encode() + body


rng = np.random.default_rng(13)

# PFM
put("pfm", "valid_le_3x2.pfm", pfm(3, 2, [0, 1.5, float("inf"), -2, 3.25, 1e30]))
put("pfm", "valid_be_2x2.pfm", pfm(2, 2, [1, 2, 3, float("nan")], scale="1.0"))
put("pfm", "colour.pfm", pfm(1, 1, [1, 2, 3], magic="PF"))
put("pfm", "truncated.pfm", pfm(4, 4, [1.0] * 5))
put("pfm", "huge_header.pfm", "Pf\n100000 100000\n-1.0\n")
put("pfm", "bad_scale.pfm", "Pf\n1 1\nabc\n\0\0\0\0")

# PLY
put("ply", "ascii_colour.ply", "ply\nformat ascii 1.0\ncomment c\nelement vertex 3\nproperty float x\nproperty float y\n"
    "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
    "0 0 1 255 0 0\n1 0 2 0 255 0\n0 1 3 0 0 255\n")
put("ply", "binary.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
    b"property float z\nproperty double extra\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
    + struct.pack("<fffd", 1, 2, 3, 4) + struct.pack("<fffd", 5, 6, 7, 8) + struct.pack("<Biii", 3, 0, 1, 0))
put("ply", "no_z.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n")
put("ply", "truncated.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 9\nproperty float x\n"
    b"property float y\nproperty float z\nend_header\n" + struct.pack("<fff", 1, 2, 3))
put("ply", "big_endian.ply", "ply\nformat binary_big_endian 1.0\nelement vertex 1\nproperty float x\nend_header\n")
put("ply", "huge_count.ply", "ply\nformat ascii 1.0\nelement vertex 99999999999\nproperty float x\nproperty float y\n"
    "property float z\nend_header\n1 2 3\n")

# Calibration: the first byte picks the extension (% 6: .txt .yml .yaml .json .xml none) and, when
# (byte / 6) is odd, an image size given to the reader.
middlebury = ("cam0=[1733.74 0 792.27; 0 1733.74 541.89; 0 0 1]\ncam1=[1733.74 0 792.27; 0 1733.74 541.89; 0 0 1]\n"
              "doffs=0\nbaseline=536.62\nwidth=64\nheight=48\nndisp=170\nvmin=55\nvmax=142\n")
put("calibration", "middlebury.txt", b"\x00" + middlebury.encode())
put("calibration", "middlebury_bad_matrix.txt", b"\x00" + b"cam0=[1 2; 3]\nbaseline=1\n")
P1 = np.array([[500, 0, 31.5, 0], [0, 500, 23.5, 0], [0, 0, 1, 0]], np.float64)
P2 = P1.copy()
P2[0, 3] = -500 * 0.12
K = np.array([[500, 0, 32], [0, 500, 24], [0, 0, 1]], np.float64)
D = np.zeros((1, 5))
R = np.eye(3)
T = np.array([[-0.12], [0.0], [0.0]])


def storage(ext, keys):
    path = "/tmp/mctstereo-corpus" + ext
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_WRITE)
    for k, v in keys:
        fs.write(k, v)
    fs.release()
    with open(path, "rb") as f:
        data = f.read()
    os.remove(path)
    return data


rectified = [("image_width", 64), ("image_height", 48), ("P1", P1), ("P2", P2), ("units", "m")]
raw = [("image_width", 64), ("image_height", 48), ("K1", K), ("D1", D), ("K2", K), ("D2", D), ("R", R), ("T", T)]
put("calibration", "projections.yml", b"\x01" + storage(".yml", rectified))
put("calibration", "raw_rig.yaml", b"\x02" + storage(".yml", raw))
put("calibration", "raw_rig_sized.yml", b"\x07" + storage(".yml", raw[2:]))
put("calibration", "projections.json", b"\x03" + storage(".json", rectified))
put("calibration", "projections.xml", b"\x04" + storage(".xml", rectified))
put("calibration", "q_only.xml", b"\x05" + storage(".xml", [("Q", np.array(
    [[1, 0, 0, -31.5], [0, 1, 0, -23.5], [0, 0, 0, 500], [0, 0, 1 / 0.12, 0]], np.float64))]))
put("calibration", "nested.yml", b"\x01%YAML:1.0\nP1: " + b"[" * 80 + b"]" * 80 + b"\n")
put("calibration", "garbage.yml", b"\x01P1: [ [ [ { : : : ]]] ,,,\n")
put("calibration", "unknown_unit.yml", b"\x01" + storage(".yml", rectified[:-1] + [("units", "parsec")]))

# scene.txt, in a folder holding imL.png, imR.png (8 x 6), gt.pfm, gt_right.pfm, gt.png,
# nonocc.png, all.png and disc.png (see fuzz_scene.cpp).
put("scene", "pfm_gt.txt", "scene=s\nleft=imL.png\nright=imR.png\ngt=gt.pfm\nmax_disp=4\n")
put("scene", "png_gt_masks.txt", "# comment\nleft=imL.png\nright=imR.png\ngt=gt.png\ngt_scale=4\ngt_invalid=0\n"
    "min_disp=-2\nmax_disp=15\nmasks=nonocc.png all.png disc.png\n")
put("scene", "gt_right.txt", "left=imL.png\nright=imR.png\ngt=gt.pfm\ngt_right=gt_right.pfm\ngt_scale=0.5\nmax_disp=9.5\n")
put("scene", "no_max.txt", "left=imL.png\nright=imR.png\ngt=gt.pfm\n")
put("scene", "huge_max.txt", "left=imL.png\nright=imR.png\ngt=gt.pfm\nmax_disp=99999999999\n")
put("scene", "wrong_file.txt", "left=imL.png\nright=gt.pfm\ngt=imR.png\nmax_disp=3\ngt_view=right\n")

# Images: the program's formats (PNG, PNM, JPEG) and a few others OpenCV decodes.
gray = rng.integers(0, 256, (6, 8), dtype=np.uint8)
bgra = rng.integers(0, 256, (5, 7, 4), dtype=np.uint8)
put("image", "gray.png", cv2.imencode(".png", gray)[1].tobytes())
put("image", "bgra.png", cv2.imencode(".png", bgra)[1].tobytes())
put("image", "deep.png", cv2.imencode(".png", gray.astype(np.uint16) * 257)[1].tobytes())
put("image", "gray.pgm", cv2.imencode(".pgm", gray)[1].tobytes())
put("image", "colour.ppm", cv2.imencode(".ppm", bgra[:, :, :3])[1].tobytes())
put("image", "colour.jpg", cv2.imencode(".jpg", bgra[:, :, :3])[1].tobytes())
put("image", "gray.bmp", cv2.imencode(".bmp", gray)[1].tobytes())
png = cv2.imencode(".png", gray)[1].tobytes()
put("image", "truncated.png", png[: len(png) // 2])
put("image", "huge.png", png[:16] + struct.pack(">II", 100000, 100000) + png[24:])
put("image", "huge.pgm", "P5\n# c\n40000 2\n255\n")
put("image", "text.txt", "not an image\n")

# Parameters: bytes read in order by fuzz_params.cpp; a few arbitrary starts.
for i in range(4):
    put("params", "random_%d" % i, rng.integers(0, 256, 96 + 64 * i, dtype=np.uint8).tobytes())
put("params", "zeros", bytes(128))
put("params", "ones", b"\xff" * 128)
print("wrote", sum(len(files) for _, _, files in os.walk(ROOT)), "files under", ROOT, file=sys.stderr)
