"""Batches of stereo pairs on Dask: one task per pair, on a local cluster or the user's.

    python3 -m mctstereo.batch PAIRS --out DIR [--scheduler ADDRESS] [--workers N] [match options]

PAIRS is a CSV file of `left,right[,calibration]` paths (relative paths are relative to the CSV's
folder; a first row `left,right,...` is a header; `#` starts a comment) or a folder of pairs:

- `NAME_left.EXT` and `NAME_right.EXT` side by side (the pair NAME), or
- `left/NAME.EXT` and `right/NAME.EXT` subfolders (the pair NAME), or
- one subfolder per scene holding `im0.EXT` and `im1.EXT` (Middlebury 2014) or `imL.EXT` and
  `imR.EXT` (the pair is the subfolder's name), with the scene's `calib.txt` when it has one.

EXT is png, ppm, pgm, jpg or jpeg. A CSV pair is named after its left image: its path relative to
the folder all left images share, without extension and a trailing `_left`, `/` read as `_`.

For each pair NAME the batch writes into DIR what `mctstereo match` writes:
  NAME.pfm          the left disparity (`match -o NAME.pfm`), +INF where there is none;
  NAME_color.png    with --preview, the colour preview (`match --color`);
  NAME_depth.pfm    with a calibration, the depth in the units of the baseline (`match --depth`);
each written to a temporary file in DIR first and renamed into place, so that a file under its
final name is complete. A rerun skips the pairs whose outputs are all there. summary.csv (or
--summary) has one row per pair: pair, size, ms, valid %, status (ok, skipped, failed), error.
A failed pair (missing or damaged file, size mismatch, bad calibration) is a row of the summary;
the batch goes on, and exits with status 1 at the end.

Without --scheduler a local cluster of --workers processes starts on 127.0.0.1 (the dashboard
only with --dashboard, on 127.0.0.1), each worker running one pair at a time with cores / workers
matcher threads. With --scheduler tcp://HOST:PORT the pairs go to that cluster; the workers
must see the same paths (a shared file system) and import mctstereo.
"""

import argparse
import csv
import io
import os
import pathlib
import sys
import threading
import time
from dataclasses import dataclass
from typing import Optional

import numpy as np

from . import Matcher, StereoParams, depth_from_disparity, encode_pfm, preset, read_pfm
from .calibration import read_geometry

IMAGE_EXTENSIONS = (".png", ".ppm", ".pgm", ".jpg", ".jpeg")
SUMMARY_FIELDS = ["pair", "size", "ms", "valid_percent", "status", "error", "left", "right", "calibration"]


@dataclass(frozen=True)
class Pair:
    name: str
    left: str
    right: str
    calibration: str = ""


@dataclass(frozen=True)
class MatchSettings:
    """What every task needs: the parameters (as StereoParams.to_dict()), where outputs go."""

    params: dict
    out: str
    backend: str = "cpu"
    device: str = ""
    threads: int = 0
    preview: bool = False


@dataclass
class PairResult:
    pair: Pair
    status: str = "failed"  # ok, skipped, failed
    width: int = 0
    height: int = 0
    ms: Optional[float] = None
    valid_percent: Optional[float] = None
    error: str = ""

    def row(self):
        return {
            "pair": self.pair.name,
            "size": f"{self.width}x{self.height}" if self.width else "",
            "ms": "" if self.ms is None else f"{self.ms:.1f}",
            "valid_percent": "" if self.valid_percent is None else f"{self.valid_percent:.1f}",
            "status": self.status,
            "error": self.error,
            "left": self.pair.left,
            "right": self.pair.right,
            "calibration": self.pair.calibration,
        }


class UsageError(Exception):
    """A mistake in the command line or the list of pairs: nothing is matched."""


# ---- The list of pairs.


def _strip_suffix(name, suffixes=("_left", "-left")):
    for suffix in suffixes:
        if name.lower().endswith(suffix) and len(name) > len(suffix):
            return name[: -len(suffix)]
    return name


def _name_from_left(left, common):
    relative = pathlib.Path(os.path.relpath(left, common)).with_suffix("")
    return _strip_suffix("_".join(relative.parts))


def pairs_from_csv(path):
    path = pathlib.Path(path)
    base = path.resolve().parent
    rows = []
    with open(path, newline="") as f:
        for number, cells in enumerate(csv.reader(f), 1):
            cells = [c.strip() for c in cells]
            if not any(cells) or cells[0].startswith("#"):
                continue
            if not rows and cells[0].lower() == "left":
                continue  # the header
            if len(cells) not in (2, 3) or not cells[0] or not cells[1]:
                raise UsageError(f"{path}, line {number}: expected left,right[,calibration], got {len(cells)} fields")
            rows.append([str(base / c) if c else "" for c in cells] + [""] * (3 - len(cells)))
    if not rows:
        raise UsageError(f"{path}: no pairs")
    common = os.path.commonpath([os.path.dirname(r[0]) for r in rows])
    return [Pair(_name_from_left(r[0], common), r[0], r[1], r[2]) for r in rows]


def _images(folder):
    """The images of a folder by stem (name without extension)."""
    if not folder.is_dir():
        return {}
    return {p.stem: str(p) for p in sorted(folder.iterdir()) if p.is_file() and p.suffix.lower() in IMAGE_EXTENSIONS}


def _right_stem(stem, base):
    """NAME_right of NAME_left, in the case of its word: NAME-RIGHT of NAME-LEFT."""
    separator, word = stem[len(base)], stem[len(base) + 1:]
    return base + separator + ("RIGHT" if word.isupper() else "Right" if word[0].isupper() else "right")


def _scene_pair(scene):
    images = _images(scene)
    for left_stem, right_stem in (("im0", "im1"), ("imL", "imR")):
        if left_stem in images:
            calib = scene / "calib.txt"
            calibration = str(calib) if calib.is_file() else ""
            return Pair(scene.name, images[left_stem], images.get(right_stem, ""), calibration)
    return None


def pairs_from_folder(folder):
    folder = pathlib.Path(folder).resolve()
    pairs = []
    if (folder / "left").is_dir() and (folder / "right").is_dir():
        rights = _images(folder / "right")
        pairs = [Pair(stem, left, rights.get(stem, "")) for stem, left in _images(folder / "left").items()]
    else:
        images = _images(folder)
        for stem, left in images.items():
            base = _strip_suffix(stem)
            if base != stem:
                pairs.append(Pair(base, left, images.get(_right_stem(stem, base), "")))
        for scene in sorted(d for d in folder.iterdir() if d.is_dir()):
            pair = _scene_pair(scene)
            if pair:
                pairs.append(pair)
    if not pairs:
        raise UsageError(f"{folder}: no pairs (NAME_left.EXT + NAME_right.EXT, left/ + right/ subfolders, "
                         "or scene subfolders with im0 + im1 or imL + imR)")
    return pairs


def read_pairs(source):
    """The pairs of a CSV file or a folder; UsageError for a list the batch cannot run."""
    source = pathlib.Path(source)
    if source.is_dir():
        pairs = pairs_from_folder(source)
    elif source.is_file():
        pairs = pairs_from_csv(source)
    else:
        raise UsageError(f"{source}: no such file or folder")
    seen = {}
    for pair in pairs:
        if pair.name in seen:
            raise UsageError(f"pairs {seen[pair.name].left} and {pair.left} would both be named '{pair.name}'")
        seen[pair.name] = pair
    return pairs


def output_paths(out, name, preview, calibrated):
    """The files of one pair, by role: disparity, and preview and depth when asked for."""
    out = pathlib.Path(out)
    paths = {"disparity": out / f"{name}.pfm"}
    if preview:
        paths["preview"] = out / f"{name}_color.png"
    if calibrated:
        paths["depth"] = out / f"{name}_depth.pfm"
    return {role: str(p) for role, p in paths.items()}


# ---- Files as `mctstereo match` writes them (PFM: the library's encode_pfm and read_pfm).


def disparity_from_q4(q4, invalid_q4):
    """Pixels from the Q4 map, as the program converts it for a PFM: q4 / 16, +INF where invalid."""
    values = q4.astype(np.float32) / np.float32(16)
    values[q4 == invalid_q4] = np.inf
    return values


def encode_preview(q4, invalid_q4, dmin, dmax):
    """The program's --color PNG: turbo colormap over [dmin, dmax], black where invalid."""
    import cv2

    lo, span = 16.0 * dmin, 16.0 * max(dmax - dmin, 1)
    level = np.clip(np.floor(255.0 * (q4.astype(np.float64) - lo) / span + 0.5), 0, 255).astype(np.uint8)
    colour = cv2.applyColorMap(level, cv2.COLORMAP_TURBO)
    colour[q4 == invalid_q4] = 0
    ok, png = cv2.imencode(".png", colour)
    if not ok:
        raise RuntimeError("cannot encode the preview as PNG")
    return png.tobytes()


def write_atomically(path, data):
    """Writes data to a hidden temporary file in path's folder, then renames it to path."""
    folder, name = os.path.split(path)
    temporary = os.path.join(folder, f".{name}.tmp-{os.getpid()}-{threading.get_ident()}")
    try:
        with open(temporary, "wb") as f:
            f.write(data)
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.remove(temporary)
        raise


def _signature(data):
    if data[:4] == b"\x89PNG":
        return "PNG"
    if data[:3] == b"\xff\xd8\xff":
        return "JPEG"
    if data[:1] == b"P" and data[1:2] in b"123456" and data[1:2]:
        return "PGM" if data[1:2] in b"25" else "PPM"
    return ""


def read_image(path, role):
    """An 8-bit image as the program reads it: gray, BGR, or BGRA and gray+alpha without alpha."""
    import cv2

    what = f"cannot read {role} '{path}': "
    if not os.path.exists(path):
        raise RuntimeError(what + "no such file")
    if os.path.isdir(path):
        raise RuntimeError(what + "it is a folder, not an image")
    data = pathlib.Path(path).read_bytes()
    if not data:
        raise RuntimeError(what + "the file is empty")
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if image is None or image.size == 0:
        claimed = _signature(data)
        raise RuntimeError(f"cannot decode {role} '{path}': " +
                           (f"damaged or truncated {claimed} file" if claimed else "not a PNG, PPM, PGM or JPEG image"))
    if image.dtype != np.uint8:
        raise RuntimeError(f"{role} '{path}' has {image.dtype} samples; only 8-bit images are matched")
    if image.ndim == 3 and image.shape[2] == 2:
        image = np.ascontiguousarray(image[:, :, 0])
    elif image.ndim == 3 and image.shape[2] == 4:
        image = cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
    return image


def _output_complete(path):
    if not os.path.isfile(path) or os.path.getsize(path) == 0:
        return False
    if path.endswith(".pfm"):
        try:
            read_pfm(path)
        except (RuntimeError, OSError):
            return False
    return True


# ---- One pair, on a worker.

_matchers = threading.local()  # per worker thread: the matcher of the last size and settings


def _matcher(width, height, settings):
    key = (width, height, tuple(sorted(settings.params.items())), settings.backend, settings.device, settings.threads)
    if getattr(_matchers, "key", None) != key:
        _matchers.matcher = None  # frees the old one's buffers before the new one allocates
        params = StereoParams(**settings.params)
        _matchers.matcher = Matcher(width, height, params, settings.backend, settings.threads, settings.device)
        _matchers.key = key
    return _matchers.matcher


def _skip_if_complete(result, paths):
    """Fills result from the outputs of an earlier run when they are all there; False otherwise."""
    if not all(_output_complete(p) for p in paths.values()):
        return False
    disparity = read_pfm(paths["disparity"])
    result.height, result.width = disparity.shape
    result.valid_percent = 100.0 * float(np.isfinite(disparity).mean())
    result.status = "skipped"
    return True


def match_pair(pair, settings):
    """Matches one pair and writes its outputs; a PairResult, never an exception (a failure is a row)."""
    result = PairResult(pair)
    paths = output_paths(settings.out, pair.name, settings.preview, bool(pair.calibration))
    try:
        if _skip_if_complete(result, paths):
            return result
        left = read_image(pair.left, "left image")
        right = read_image(pair.right, "right image") if pair.right else None
        if right is None:
            raise RuntimeError(f"no right image for '{pair.left}'")
        (h, w), (rh, rw) = left.shape[:2], right.shape[:2]
        if (w, h) != (rw, rh):
            raise RuntimeError(f"left image '{pair.left}' is {w}x{h} but right image '{pair.right}' is {rw}x{rh}: "
                               "a stereo pair has one size")
        result.width, result.height = w, h
        geometry = None
        if pair.calibration:
            geometry = read_geometry(pair.calibration, w, h)
        matcher = _matcher(w, h, settings)
        start = time.perf_counter()
        matcher.compute(left, right)
        result.ms = 1000.0 * (time.perf_counter() - start)
        q4, invalid = matcher.disparity_q4(), matcher.invalid_q4
        result.valid_percent = 100.0 * float((q4 != invalid).mean())
        _write_outputs(paths, matcher, q4, invalid, geometry)
        result.status = "ok"
    except Exception as e:  # noqa: BLE001 - any failure of one pair is that pair's row
        result.status, result.error = "failed", str(e) or type(e).__name__
    return result


def _write_outputs(paths, matcher, q4, invalid, geometry):
    # The disparity last: its presence marks the pair done for a rerun.
    if "preview" in paths:
        p = matcher.params
        write_atomically(paths["preview"], encode_preview(q4, invalid, p.min_disparity, p.max_disparity()))
    if geometry is not None:
        depth = depth_from_disparity(q4, geometry, invalid_q4=invalid)
        write_atomically(paths["depth"], encode_pfm(depth))
    write_atomically(paths["disparity"], encode_pfm(disparity_from_q4(q4, invalid)))


# ---- The batch, from the client.


def _progress_line(done, total, result):
    r = result
    if r.status == "failed":
        what = f"FAILED: {r.error}"
    elif r.status == "skipped":
        what = f"skipped, outputs complete ({r.width}x{r.height}, valid {r.valid_percent:.1f} %)"
    else:
        what = f"{r.width}x{r.height}, {r.ms:.1f} ms, valid {r.valid_percent:.1f} %"
    return f"[{done:>{len(str(total))}}/{total}] {r.pair.name}: {what}"


def run_batch(client, pairs, settings, log=sys.stderr):
    """Submits one task per pair and collects their results in the order of pairs, printing a line
    per finished pair to log. A task whose worker died is a failed row too."""
    from distributed import as_completed

    futures = [client.submit(match_pair, pair, settings, key=f"mctstereo-{i}-{pair.name}", pure=False)
               for i, pair in enumerate(pairs)]
    index = {f.key: i for i, f in enumerate(futures)}
    results = [None] * len(pairs)
    for done, future in enumerate(as_completed(futures), 1):
        i = index[future.key]
        try:
            results[i] = future.result()
        except Exception as e:  # noqa: BLE001 - the worker failed, not the pair's code
            results[i] = PairResult(pairs[i], error=f"task failed: {e or type(e).__name__}")
        if log:
            print(_progress_line(done, len(pairs), results[i]), file=log, flush=True)
    return results


def write_summary(results, path):
    text = io.StringIO()
    writer = csv.DictWriter(text, SUMMARY_FIELDS, lineterminator="\n")
    writer.writeheader()
    for r in results:
        writer.writerow(r.row())
    write_atomically(str(path), text.getvalue().encode())


def start_client(scheduler, workers, dashboard):
    """A client of the user's cluster, or of a local one on 127.0.0.1 (one pair at a time per worker)."""
    from distributed import Client, LocalCluster

    if scheduler:
        return Client(scheduler), None
    # Every node serves HTTP (health, metrics) even without a dashboard, on all interfaces unless
    # told an address: the scheduler's and the workers' are bound to 127.0.0.1 too.
    scheduler_http = {"dashboard": True, "dashboard_address": "127.0.0.1:8787"} if dashboard else {
        "dashboard": False, "dashboard_address": "127.0.0.1:0"}
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                           scheduler_kwargs=scheduler_http, worker_dashboard_address="127.0.0.1:0")
    return Client(cluster), cluster


def _field_value(text):
    lowered = text.lower()
    if lowered in ("true", "on", "yes"):
        return True
    if lowered in ("false", "off", "no"):
        return False
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def parameters_from(args):
    """The StereoParams of the command line (preset, then the range flags, then --set), validated."""
    try:
        params = preset(args.preset)
        if args.min_disparity is not None:
            params.min_disparity = args.min_disparity
        if args.num_disparities is not None:
            params.num_disparities = args.num_disparities
        for assignment in args.set:
            name, _, value = assignment.partition("=")
            name = name.strip().replace("-", "_")
            if not hasattr(params, name) or name.startswith("_"):
                raise UsageError(f"--set {assignment}: StereoParams has no field '{name}'")
            setattr(params, name, _field_value(value.strip()))
            if name == "aggregation" and value.strip() == "box":
                params.prior_size = 3  # as the program's --aggregation box
        params.validate()
    except (ValueError, TypeError) as e:
        raise UsageError(str(e)) from None
    return params


def argument_parser():
    parser = argparse.ArgumentParser(
        prog="python3 -m mctstereo.batch",
        description="Match many stereo pairs on a Dask cluster (a local one unless --scheduler is given).",
        epilog=__doc__.split("\n\n", 2)[2], formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("pairs", metavar="PAIRS", help="CSV of left,right[,calibration] paths, or a folder of pairs")
    parser.add_argument("--out", required=True, help="folder of the outputs (made if missing)")
    parser.add_argument("--summary", help="the summary CSV (default OUT/summary.csv)")
    parser.add_argument("--preview", action="store_true", help="also write NAME_color.png as match --color does")
    cluster = parser.add_argument_group("cluster")
    cluster.add_argument("--scheduler", help="address of a running Dask scheduler, e.g. tcp://10.0.0.5:8786")
    cluster.add_argument("--workers", type=int, default=2, help="worker processes of the local cluster (default 2)")
    cluster.add_argument("--dashboard", action="store_true",
                         help="serve the local cluster's dashboard on http://127.0.0.1:8787")
    match = parser.add_argument_group("matching (as mctstereo match)")
    match.add_argument("--preset", default="balanced", help="named parameter set (default balanced)")
    match.add_argument("--min-disparity", type=int, help="smallest disparity searched, pixels")
    match.add_argument("--num-disparities", type=int, help="number of disparities searched")
    match.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                       help="any other StereoParams field, e.g. --set aggregation=sgm8 (repeatable)")
    match.add_argument("--backend", default="cpu", choices=["cpu", "reference", "opencl", "auto"],
                       help="where matching runs (default cpu)")
    match.add_argument("--device", default="", help="OpenCL device of --backend opencl")
    match.add_argument("--threads", type=int,
                       help="matcher threads per worker (default: cores / workers on a local cluster, "
                            "all cores of the worker's machine with --scheduler)")
    return parser


def prepare(args):
    """The settings and pairs of the command line, the output folder made; UsageError for a mistake."""
    if args.workers < 1:
        raise UsageError("--workers must be at least 1")
    params = parameters_from(args)
    pairs = read_pairs(args.pairs)
    out = pathlib.Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    inputs = {os.path.realpath(p) for pair in pairs for p in (pair.left, pair.right, pair.calibration) if p}
    for pair in pairs:
        for path in output_paths(out, pair.name, args.preview, bool(pair.calibration)).values():
            if os.path.realpath(path) in inputs:
                raise UsageError(f"output '{path}' is an input: refusing to overwrite it")
    threads = args.threads
    if threads is None:  # a local cluster shares this machine's cores among its workers
        threads = 0 if args.scheduler else max(1, (os.cpu_count() or 1) // args.workers)
    return MatchSettings(params.to_dict(), str(out), args.backend, args.device, threads, args.preview), pairs


def run_on_cluster(args, pairs, settings):
    """The results of the pairs and the seconds they took, on the user's cluster or a local one."""
    client, cluster = start_client(args.scheduler, args.workers, args.dashboard)
    if args.dashboard and cluster is not None:
        print(f"mctstereo.batch: dashboard {client.dashboard_link}", file=sys.stderr)
    try:
        start = time.perf_counter()
        results = run_batch(client, pairs, settings)
        return results, time.perf_counter() - start
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def main(argv=None):
    args = argument_parser().parse_args(argv)
    try:
        settings, pairs = prepare(args)
    except UsageError as e:
        print(f"mctstereo.batch: {e}", file=sys.stderr)
        return 2
    try:
        results, seconds = run_on_cluster(args, pairs, settings)
    except (OSError, TimeoutError) as e:
        where = f"the scheduler {args.scheduler}" if args.scheduler else "the local cluster"
        print(f"mctstereo.batch: lost or could not reach {where}: {e}", file=sys.stderr)
        return 2
    summary = pathlib.Path(args.summary) if args.summary else pathlib.Path(settings.out) / "summary.csv"
    summary.parent.mkdir(parents=True, exist_ok=True)
    write_summary(results, summary)
    counts = {s: sum(r.status == s for r in results) for s in ("ok", "skipped", "failed")}
    print(f"mctstereo.batch: {len(results)} pairs in {seconds:.1f} s ({len(results) / seconds:.2f} pairs/s): "
          f"{counts['ok']} matched, {counts['skipped']} skipped, {counts['failed']} failed; summary {summary}",
          file=sys.stderr)
    return 1 if counts["failed"] else 0


if __name__ == "__main__":
    # The tasks must name the functions of mctstereo.batch, which workers import, not of __main__.
    from mctstereo.batch import main as batch_main

    sys.exit(batch_main())
