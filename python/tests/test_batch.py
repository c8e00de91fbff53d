# Batches on Dask: 20 pairs made from the bundled pair (a copy with a calibration, shifted crops, a
# damaged file, a size mismatch) on a local cluster of 2 workers; outputs equal a direct Matcher
# run and the program's files byte for byte; failures are rows; a rerun skips finished pairs.
import csv
import os
import subprocess
import sys

import numpy as np
import pytest

import mctstereo
from conftest import TSUKUBA, read_pnm, run_cli

cv2 = pytest.importorskip("cv2")
pytest.importorskip("distributed")
from mctstereo import batch  # noqa: E402

NUM_DISPARITIES = 16
CALIB = "cam0=[400 0 191.5; 0 400 143.5; 0 0 1]\ncam1=[400 0 193.5; 0 400 143.5; 0 0 1]\nbaseline=160\nwidth=384\nheight=288\n"


def make_pairs(folder):
    """scene/{im0,im1}.png + calib.txt (the bundled pair), 17 shifted crops NAME_left/right.png,
    a truncated PNG and a right image of another size: 20 pairs."""
    left, right = (read_pnm(TSUKUBA / f"im{s}.ppm")[:, :, ::-1] for s in "LR")  # BGR, as OpenCV writes
    (folder / "scene").mkdir()
    cv2.imwrite(str(folder / "scene" / "im0.png"), left)
    cv2.imwrite(str(folder / "scene" / "im1.png"), right)
    (folder / "scene" / "calib.txt").write_text(CALIB)
    for i in range(17):
        x, y, w, h = 4 * i, 3 * (i % 5), 320 - 8 * (i % 3), 240
        cv2.imwrite(str(folder / f"crop{i:02d}_left.png"), left[y:y + h, x:x + w])
        cv2.imwrite(str(folder / f"crop{i:02d}_right.png"), right[y:y + h, x:x + w])
    cv2.imwrite(str(folder / "damaged_left.png"), left)
    whole = cv2.imencode(".png", right)[1].tobytes()
    (folder / "damaged_right.png").write_bytes(whole[: len(whole) // 2])
    cv2.imwrite(str(folder / "mismatch_left.png"), left)
    cv2.imwrite(str(folder / "mismatch_right.png"), right[:, :200])


def run_batch(pairs, out, *extra):
    command = [sys.executable, "-m", "mctstereo.batch", str(pairs), "--out", str(out), "--workers", "2",
               "--num-disparities", str(NUM_DISPARITIES), "--preview", *map(str, extra)]
    return subprocess.run(command, capture_output=True, text=True, timeout=300)


def summary_rows(out):
    with open(out / "summary.csv", newline="") as f:
        return {row["pair"]: row for row in csv.DictReader(f)}


@pytest.fixture(scope="module")
def first_run(tmp_path_factory):
    pairs, out = tmp_path_factory.mktemp("pairs"), tmp_path_factory.mktemp("out")
    make_pairs(pairs)
    result = run_batch(pairs, out)
    return pairs, out, result


def test_summary_has_every_pair_and_the_failures_as_rows(first_run):
    pairs, out, result = first_run
    assert result.returncode == 1, result.stderr  # two pairs failed, the other 18 were matched
    rows = summary_rows(out)
    assert len(rows) == 20
    ok = [r for r in rows.values() if r["status"] == "ok"]
    assert len(ok) == 18
    assert rows["scene"]["size"] == "384x288" and float(rows["scene"]["ms"]) > 0
    assert rows["crop01"]["size"] == "312x240"
    assert all(80.0 < float(r["valid_percent"]) <= 100.0 for r in ok)
    assert rows["damaged"]["status"] == "failed"
    assert "damaged or truncated PNG file" in rows["damaged"]["error"]
    assert rows["mismatch"]["status"] == "failed"
    assert "is 384x288 but right image" in rows["mismatch"]["error"] and "200x288" in rows["mismatch"]["error"]
    assert not (out / "damaged.pfm").exists() and not (out / "mismatch.pfm").exists()
    # A line per pair on stderr, then the totals.
    assert result.stderr.count("] ") >= 20 and "18 matched, 0 skipped, 2 failed" in result.stderr
    assert not [p for p in os.listdir(out) if p.startswith(".")]  # no temporary file left


def test_outputs_equal_a_direct_matcher_run(first_run):
    pairs, out, _ = first_run
    for name in ["scene"] + [f"crop{i:02d}" for i in range(17)]:
        left_path = pairs / "scene" / "im0.png" if name == "scene" else pairs / f"{name}_left.png"
        right_path = pairs / "scene" / "im1.png" if name == "scene" else pairs / f"{name}_right.png"
        left, right = cv2.imread(str(left_path)), cv2.imread(str(right_path))
        matcher = mctstereo.Matcher(left.shape[1], left.shape[0], mctstereo.preset("balanced", num_disparities=16))
        disparity = matcher.compute(left, right)
        written = mctstereo.read_pfm(out / f"{name}.pfm")
        np.testing.assert_array_equal(np.isinf(written), np.isnan(disparity))
        valid = ~np.isnan(disparity)
        assert written[valid].tobytes() == disparity[valid].tobytes(), name


def test_outputs_equal_the_programs_files_byte_for_byte(first_run, cli, tmp_path):
    pairs, out, _ = first_run
    scene = pairs / "scene"
    run_cli(cli, "match", scene / "im0.png", scene / "im1.png", "--num-disparities", NUM_DISPARITIES,
            "-o", tmp_path / "d.pfm", "--color", tmp_path / "c.png", "--calib", scene / "calib.txt",
            "--depth", tmp_path / "z.pfm")
    assert (out / "scene.pfm").read_bytes() == (tmp_path / "d.pfm").read_bytes()
    assert (out / "scene_color.png").read_bytes() == (tmp_path / "c.png").read_bytes()
    assert (out / "scene_depth.pfm").read_bytes() == (tmp_path / "z.pfm").read_bytes()


def test_rerun_skips_the_pairs_whose_outputs_are_complete(first_run):
    pairs, out, _ = first_run
    before = {p: os.stat(out / p).st_mtime_ns for p in os.listdir(out) if p != "summary.csv"}
    os.remove(out / "crop03_color.png")  # an incomplete pair is matched again
    result = run_batch(pairs, out)
    assert result.returncode == 1, result.stderr
    rows = summary_rows(out)
    assert [name for name, r in rows.items() if r["status"] == "ok"] == ["crop03"]
    assert sum(r["status"] == "skipped" for r in rows.values()) == 17
    assert rows["scene"]["size"] == "384x288" and rows["scene"]["valid_percent"]
    assert {name for name, r in rows.items() if r["status"] == "failed"} == {"damaged", "mismatch"}
    for path, mtime in before.items():
        if not path.startswith("crop03"):
            assert os.stat(out / path).st_mtime_ns == mtime, path
    assert (out / "crop03_color.png").exists()


def test_local_cluster_listens_on_loopback_only():
    psutil = pytest.importorskip("psutil")
    client, cluster = batch.start_client(None, 2, False)
    try:
        processes = [psutil.Process()] + psutil.Process().children(recursive=True)
        listening = [c.laddr for p in processes for c in p.connections("tcp") if c.status == psutil.CONN_LISTEN]
        assert len(listening) >= 3  # the scheduler and two workers at least
        assert all(address.ip == "127.0.0.1" for address in listening), listening
    finally:
        client.close()
        cluster.close()


def test_scheduler_address_sends_the_pairs_to_that_cluster(tmp_path):
    left, right = (read_pnm(TSUKUBA / f"im{s}.ppm") for s in "LR")
    for name in ("a", "b"):
        cv2.imwrite(str(tmp_path / f"{name}_left.png"), left)
        cv2.imwrite(str(tmp_path / f"{name}_right.png"), right)
    client, cluster = batch.start_client(None, 1, False)  # the user's cluster, as far as the batch knows
    try:
        transitions = cluster.scheduler.transition_counter
        result = run_batch(tmp_path, tmp_path / "out", "--scheduler", cluster.scheduler_address)
        assert result.returncode == 0, result.stderr
        assert "2 matched" in result.stderr
        assert cluster.scheduler.transition_counter >= transitions + 2 * 3  # released, waiting, processing, memory
    finally:
        client.close()
        cluster.close()
    assert (tmp_path / "out" / "a.pfm").read_bytes() == (tmp_path / "out" / "b.pfm").read_bytes()


def test_pairs_from_a_csv(tmp_path):
    (tmp_path / "cam" / "left").mkdir(parents=True)
    (tmp_path / "list.csv").write_text(
        "left,right,calibration\n# a comment\ncam/left/a_left.png,cam/r/a.png\n"
        f"cam/left/b.png,{tmp_path}/b_r.png,calib.txt\n")
    pairs = batch.read_pairs(tmp_path / "list.csv")
    assert [p.name for p in pairs] == ["a", "b"]
    assert pairs[0].right == str(tmp_path / "cam" / "r" / "a.png") and pairs[0].calibration == ""
    assert pairs[1].right == str(tmp_path / "b_r.png") and pairs[1].calibration == str(tmp_path / "calib.txt")
    (tmp_path / "bad.csv").write_text("a.png\n")
    with pytest.raises(batch.UsageError, match="line 1: expected left,right"):
        batch.read_pairs(tmp_path / "bad.csv")


def test_pairs_from_a_folder_of_left_and_right_files(tmp_path):
    for name in ("a_left.png", "a_right.png", "B-LEFT.ppm", "B-RIGHT.jpg", "c_left.png", "d_right.png", "notes.txt"):
        (tmp_path / name).write_bytes(b"")
    pairs = {p.name: p for p in batch.read_pairs(tmp_path)}
    assert set(pairs) == {"a", "B", "c"}
    assert pairs["B"].right.endswith("B-RIGHT.jpg")
    assert pairs["c"].right == ""  # matched as a failure: "no right image"


def test_pairs_from_left_and_right_subfolders(tmp_path):
    for side in ("left", "right"):
        (tmp_path / side).mkdir()
        for name in ("000001", "000002"):
            (tmp_path / side / f"{name}.png").write_bytes(b"")
    assert [(p.name, os.path.basename(p.right)) for p in batch.read_pairs(tmp_path)] == [
        ("000001", "000001.png"), ("000002", "000002.png")]


def test_bad_parameters_are_usage_errors(tmp_path):
    result = subprocess.run([sys.executable, "-m", "mctstereo.batch", str(tmp_path), "--out", str(tmp_path / "o"),
                             "--set", "census_window=4"], capture_output=True, text=True)
    assert result.returncode == 2 and "census_window" in result.stderr
    result = subprocess.run([sys.executable, "-m", "mctstereo.batch", str(tmp_path), "--out", str(tmp_path / "o")],
                            capture_output=True, text=True)
    assert result.returncode == 2 and "no pairs" in result.stderr
