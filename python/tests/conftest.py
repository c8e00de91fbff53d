# Shared helpers of the Python tests: the bundled pair as numpy arrays (binary PPM copies of the
# PNGs, data/tsukuba/im?.ppm), a PFM reader, and the mctstereo program (MCTSTEREO_CLI, set by ctest).
import os
import pathlib
import subprocess

import numpy as np
import pytest

DATA = pathlib.Path(os.environ.get("MCTSTEREO_DATA_DIR", pathlib.Path(__file__).resolve().parents[2] / "data"))
TSUKUBA = DATA / "tsukuba"


def read_pnm(path):
    """Binary PGM (P5) or PPM (P6), 8-bit: uint8 H x W or H x W x 3 (R, G, B)."""
    data = pathlib.Path(path).read_bytes()
    fields, pos = [], 0
    while len(fields) < 4:
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            pos = data.index(b"\n", pos) + 1
            continue
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    magic, w, h, maxval = fields[0], int(fields[1]), int(fields[2]), int(fields[3])
    assert magic in (b"P5", b"P6") and maxval == 255, (path, magic, maxval)
    channels = 3 if magic == b"P6" else 1
    pixels = np.frombuffer(data, np.uint8, w * h * channels, pos + 1)
    return pixels.reshape((h, w, 3) if channels == 3 else (h, w)).copy()


def read_pfm(path):
    """A one-channel PFM as the program writes it: float32 H x W, top row first."""
    data = pathlib.Path(path).read_bytes()
    lines = data.split(b"\n", 3)
    assert lines[0] == b"Pf", lines[0]
    w, h = map(int, lines[1].split())
    scale = float(lines[2])
    dtype = "<f4" if scale < 0 else ">f4"
    values = np.frombuffer(lines[3], dtype, w * h).reshape(h, w)
    return values[::-1].astype(np.float32)


@pytest.fixture(scope="session")
def tsukuba():
    """(left, right) uint8 H x W x 3, R G B."""
    return read_pnm(TSUKUBA / "imL.ppm"), read_pnm(TSUKUBA / "imR.ppm")


@pytest.fixture(scope="session")
def cli():
    path = os.environ.get("MCTSTEREO_CLI", "")
    if not path:
        pytest.skip("the mctstereo program is not built (MCTSTEREO_BUILD_APPS=OFF)")
    return path


def run_cli(cli, *args):
    result = subprocess.run([cli, *map(str, args)], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return result
