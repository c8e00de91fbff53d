#!/usr/bin/env python3
"""Rebuild docs/RESULTS.md and its figures from the JSON files that scripts/measure_results.sh writes.

    python3 scripts/make_results.py [--results DIR] [--previews DIR] [--output FILE] [--images DIR]

Inputs (in --results, default docs/results):
  eval_middlebury2003.json  mctstereo eval on the four Middlebury 2003 scenes, presets and --peers
  eval_middlebury2005.json  the same on the Middlebury 2005/2006 scenes (mask derived by LR check)
  eval_radiometric.json     mctstereo eval --radiometric --peers (the exposure study)
  bench_640x480.json        mctstereo bench at one size, every preset (the headline ratios)
  bench_640x480_repeat2.json, bench_640x480_repeat3.json
                            optional: the same size with realtime, balanced and quality, run again
                            right after it; the targets are then the median of the runs, with
                            their range
  bench_thesis.json         mctstereo bench over the thesis sizes, ranges and thread counts
  bench_backends.json       mctstereo bench with --backend reference,cpu
  bench_loaded.json         mctstereo bench with --load 2 and --threads 1,2
  bench_loaded_repeat2.json, bench_loaded_repeat3.json
                            optional: the same loaded run again; the loaded targets are then
                            checked in every run, and the speed-ups given as medians with ranges
  bench_opencl.json         mctstereo bench with --backend cpu,opencl over the thesis sizes
  bench_memory.json         mctstereo bench --memory-only over the thesis sizes and ranges
and, optionally, the disparity previews of `eval --save` (in --previews, default
build/results/previews) with the scenes' own images and ground truth (the paths in the eval JSON,
relative to the repository root).

Outputs: --output (default docs/RESULTS.md) and, in --images (default docs/images),
quality_vs_fps.png, fps_vs_resolution.png and previews_<set>.png per scene set whose previews
exist (without them, a preview image already there is kept and linked). Nothing else is written.
The same JSON files (and previews) give the same bytes: no clock is read, every list is ordered.

Every number in the report comes from the JSON files, except the project's targets (TARGET_*) and
the few published or earlier measurements in NOT_FROM_THIS_RUN, which the report labels as such.
"""

import argparse
import io
import json
import math
import os
import statistics
import sys
import textwrap

try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.image as mpimg
    import matplotlib.pyplot as plt
    import numpy as np
except ImportError as error:  # pragma: no cover - depends on the machine
    sys.exit(f"make_results.py: needs matplotlib and numpy ({error}); on Debian: apt-get install "
             "python3-matplotlib, then run it with /usr/bin/python3")

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

EVAL_2003 = "eval_middlebury2003.json"
EVAL_2005 = "eval_middlebury2005.json"
EVAL_RADIOMETRIC = "eval_radiometric.json"
BENCH_HEADLINE = "bench_640x480.json"
BENCH_HEADLINE_REPEATS = ["bench_640x480_repeat2.json", "bench_640x480_repeat3.json"]
BENCH_THESIS = "bench_thesis.json"
BENCH_BACKENDS = "bench_backends.json"
BENCH_OPENCL = "bench_opencl.json"
BENCH_LOADED = "bench_loaded.json"
BENCH_LOADED_REPEATS = ["bench_loaded_repeat2.json", "bench_loaded_repeat3.json"]
BENCH_SCALING = "bench_scaling.json"
BENCH_MEMORY = "bench_memory.json"
SEQUENCE_TEMPORAL = "sequence_temporal.json"
# The step of scripts/measure_results.sh that writes each file, for the error message.
INPUT_STEPS = {EVAL_2003: 1, EVAL_2005: 2, EVAL_RADIOMETRIC: 3, BENCH_HEADLINE: 4, BENCH_THESIS: 5, BENCH_BACKENDS: 6,
               BENCH_OPENCL: 7, BENCH_LOADED: 8, BENCH_SCALING: 9, SEQUENCE_TEMPORAL: 10, BENCH_MEMORY: 11}

THESIS_VARIANTS = [("mct-full", "MCT-full"), ("mr-mct-full", "MR-MCT-full"), ("mr-mct-5x5", "MR-MCT-5x5")]
SCENE_ORDER = ["tsukuba", "venus", "teddy", "cones", "aloe", "art"]
REGIONS = ["nonocc", "all", "disc"]
STAGES = ["gray", "pyramid", "census", "match", "refine", "wmedian", "output"]
PEER_NAMES = {"opencv-stereobm": "OpenCV StereoBM", "opencv-stereosgbm": "OpenCV StereoSGBM"}
PEER_SHORT = {"opencv-stereobm": "StereoBM", "opencv-stereosgbm": "SGBM"}
STEREOBM, STEREOSGBM = "opencv-stereobm", "opencv-stereosgbm"

# Averages of the 12 Middlebury 2003 numbers that this run does not measure.
NOT_FROM_THIS_RUN = [
    ("RTCensus", 9.7, "published"),
    ("opencv_contrib StereoBinarySGBM (census)", 12.5, "measured earlier on this kind of machine"),
    ("ELAS (Middlebury setting)", 13.9, "measured earlier on this kind of machine"),
]
# Targets of the project, checked against the measurements.
TARGET_BEST_PRESET_PERCENT_BAD = 9.5
TARGET_MULTI_RESOLUTION_PERCENT_BAD = 11.0
# At 640x480, 64 disparities, 2 threads: realtime's frame rate over StereoBM's (at least; the goal is 10).
TARGET_REALTIME_X_STEREOBM = 8.0
# realtime's time per pixel at the largest size over the smallest, --fit tile (at most), every range and thread count.
TARGET_SCALING_PER_PIXEL = 1.3
# Under --load: every preset at least as fast on 2 threads as on 1, and realtime at least this many times
# StereoBM's frame rate (2 threads).
TARGET_LOADED_REALTIME_X_STEREOBM = 3.0
# Band SGM: the Middlebury 2003 average of 12 per preset (at most), and speed at 640x480, 64
# disparities, 2 threads: balanced's frame rate over StereoBM's, quality's over StereoSGBM's (at least).
TARGET_SGM_PERCENT_BAD = {"quality": 7.5, "balanced": 8.0, "sgm-full": 7.5}
TARGET_BALANCED_X_STEREOBM = 2.0
# With the colour-weighted median: balanced's frame rate over StereoBM's (at least).
TARGET_BALANCED_WM_X_STEREOBM = 1.5
TARGET_QUALITY_X_STEREOSGBM = 2.0

# The preview rows: left image, ground truth, then these methods where the eval has them.
PREVIEW_METHODS = ["quality", "realtime", STEREOBM, STEREOSGBM]
PREVIEW_PANEL_WIDTH = 200  # pixels of one panel in the composed PNG
PREVIEW_COLOURS = 128  # of the composed PNG's palette: the maps hardly lose anything, the file halves


class InputError(Exception):
    pass


# --- Reading the JSON files, every access checked ----------------------------------------------------


class Node:
    """A JSON value with the file and key path it came from, so that every error names both."""

    def __init__(self, value, file, where=""):
        self.value, self.file, self.where = value, file, where

    def _fail(self, message):
        raise InputError(f"{self.file}: {message}")

    def _path(self, key):
        if isinstance(key, int):
            return f"{self.where}[{key}]"
        return f"{self.where}.{key}" if self.where else str(key)

    def has(self, key):
        return isinstance(self.value, dict) and key in self.value

    def __getitem__(self, key):
        if isinstance(key, int):
            if not isinstance(self.value, list):
                self._fail(f"'{self.where or '(top)'}' should be a list")
            if key >= len(self.value):
                self._fail(f"'{self.where}' has no element {key}")
            return Node(self.value[key], self.file, self._path(key))
        if not isinstance(self.value, dict):
            self._fail(f"'{self.where or '(top)'}' should be an object holding key '{key}'")
        if key not in self.value:
            self._fail(f"key '{self._path(key)}' is missing")
        return Node(self.value[key], self.file, self._path(key))

    def num(self, key, nullable=False):
        node = self[key]
        v = node.value
        if v is None and nullable:
            return None
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            self._fail(f"key '{node.where}' should be a number{' or null' if nullable else ''}, not {json.dumps(v)}")
        return float(v)

    def whole(self, key):
        v = self.num(key)
        if v != int(v):
            self._fail(f"key '{self._path(key)}' should be a whole number, not {v}")
        return int(v)

    def text(self, key, nullable=False):
        node = self[key]
        if node.value is None and nullable:
            return None
        if not isinstance(node.value, str):
            self._fail(f"key '{node.where}' should be a string, not {json.dumps(node.value)}")
        return node.value

    def array(self, key):
        node = self[key]
        if not isinstance(node.value, list):
            self._fail(f"key '{node.where}' should be a list")
        return [node[i] for i in range(len(node.value))]

    def obj(self, key):
        node = self[key]
        if not isinstance(node.value, dict):
            self._fail(f"key '{node.where}' should be an object")
        return node

    def keys(self):
        return list(self.value.keys())


def load(results_dir, name):
    path = os.path.join(results_dir, name)
    if not os.path.isfile(path):
        raise InputError(f"{path}: missing; step {INPUT_STEPS[name]} of scripts/measure_results.sh writes it")
    try:
        with open(path, encoding="utf-8") as f:
            value = json.load(f)
    except json.JSONDecodeError as error:
        raise InputError(f"{path}: not valid JSON: {error}") from None
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"{path}: cannot read it: {error}") from None
    if not isinstance(value, dict):
        raise InputError(f"{path}: should hold a JSON object")
    return Node(value, path)


def settings_of(doc):
    s = doc.obj("settings")
    keys = ["cpu_model", "simd_target", "compiler", "build_type", "date", "mctstereo_version", "opencv_version"]
    out = {k: s.text(k) for k in keys}
    out["cores_online"] = s.whole("cores_online")
    out["threads"] = s.whole("threads")
    # The program as the README builds it, wherever this run's binary was.
    line = s.text("command_line") if s.has("command_line") else None
    if line:
        first, _, rest = line.partition(" ")
        if first.endswith("mctstereo"):
            line = "build/release/apps/mctstereo" + (" " + rest if rest else "")
    out["command_line"] = line
    return out


class EvalRun:
    """One `mctstereo eval --json` file."""

    def __init__(self, doc, radiometric=False):
        self.file = doc.file
        self.settings = settings_of(doc)
        self.threshold = doc.num("threshold")
        self.presets = [p.value for p in doc.array("presets")]
        self.peers = [p.value for p in doc.array("peers")]
        self.methods = {}  # name -> summary over the scenes
        for m in doc.array("methods"):
            name = m.text("method")
            a = m.obj("average")
            self.methods[name] = {
                "kind": m.text("kind"),
                "scenes": m.whole("scenes"),
                "parameters": m.obj("parameters").value if m.has("parameters") else None,
                "average_percent_bad": m.num("average_percent_bad", nullable=True),
                "average": {k: a.num(k, nullable=True) for k in
                            ["nonocc", "all", "disc", "density", "ms", "bad_0_5", "bad_1", "bad_2", "bad_4",
                             "avgerr", "rms", "invalid", "d1", "d1_all"]},
            }
        self.method_order = [n for n in self.presets + self.peers]
        for n in self.method_order:
            if n not in self.methods:
                raise InputError(f"{self.file}: 'methods' has no entry for '{n}' (listed in presets/peers)")
        self.scenes = []
        for s in doc.array("scenes"):
            scene = {
                "name": s.text("scene"), "set": s.text("set"), "path": s.text("path"),
                "width": s.whole("width"), "height": s.whole("height"),
                "min_disparity": s.whole("min_disparity"), "num_disparities": s.whole("num_disparities"),
                "mask_source": s.text("mask_source"), "regions": [r.value for r in s.array("regions")],
                "methods": {},
            }
            for m in s.array("methods"):
                name = m.text("method")
                if m.has("skipped"):
                    scene["methods"][name] = {"skipped": m.text("skipped")}
                    continue
                entry = {"skipped": None, "average_percent_bad": m.num("average_percent_bad", nullable=True),
                         "density": m.num("density"), "ms": m.num("ms", nullable=True)}
                for r in REGIONS:
                    entry[r] = m.num(r, nullable=True)
                if m.has("sparsification"):
                    sp = m.obj("sparsification")
                    entry["sparsification"] = list(zip([f.value for f in sp.array("fractions")],
                                                       [b.value for b in sp.array("percent_bad")]))
                if radiometric:
                    entry["steps"] = {st.text("step"): st.num("average_percent_bad", nullable=True)
                                      for st in m.array("steps")}
                scene["methods"][name] = entry
            for n in self.method_order:
                if n not in scene["methods"]:
                    raise InputError(f"{self.file}: scene '{scene['name']}' has no entry for method '{n}'")
            self.scenes.append(scene)
        if not self.scenes:
            raise InputError(f"{self.file}: 'scenes' is empty")
        self.scenes.sort(key=lambda sc: scene_key(sc["name"]))
        self.radiometric = None
        if radiometric:
            r = doc.obj("radiometric")
            steps = []
            for st in r.array("steps"):
                scores = st.obj("scores")
                steps.append({"step": st.text("step"), "kind": st.text("kind"), "amount": st.num("amount"),
                              "scores": {n: scores.num(n, nullable=True) for n in self.method_order}})
            summary = {}
            for m in r.array("summary"):
                summary[m.text("method")] = {
                    "kind": m.text("kind"), "census": m.text("census", nullable=True),
                    "baseline": m.num("baseline", nullable=True), "worst": m.num("worst", nullable=True),
                    "worst_step": m.text("worst_step", nullable=True), "mean": m.num("mean", nullable=True),
                    "worst_degradation": m.num("worst_degradation", nullable=True),
                    "mean_degradation": m.num("mean_degradation", nullable=True)}
            by_change = {}
            bc = r.obj("by_change")
            for kind in bc.keys():
                node = bc.obj(kind)
                by_change[kind] = {c: node.num(c, nullable=True) for c in node.keys()}
            self.radiometric = {"headline": r.text("headline"), "seed": r.text("seed"), "steps": steps,
                                "summary": summary, "by_change": by_change, "conclusion": r.text("conclusion")}

    def presets_with(self, predicate):
        return [p for p in self.presets if self.methods[p]["parameters"] and predicate(self.methods[p]["parameters"])]


class BenchRun:
    """One `mctstereo bench --json` file."""

    def __init__(self, doc):
        self.file = doc.file
        self.settings = settings_of(doc)
        s = doc.obj("settings")
        self.sizes = [parse_size(n.value, doc.file, "settings.sizes") for n in s.array("sizes")]
        self.disparities = [n.value for n in s.array("num_disparities")]
        self.thread_settings = [n.value for n in s.array("thread_settings")]
        self.backends = [n.value for n in s.array("backends")]
        self.presets = [n.value for n in s.array("presets")]
        self.flags = {k: s.num(k) for k in ["warmup_frames", "min_frames", "min_time_s"]}
        self.images = (s.text("left_image"), s.text("right_image"))
        self.load_threads = s.whole("load_threads") if s.has("load_threads") else 0
        self.cpu_mhz = s.num("cpu_mhz") if s.has("cpu_mhz") else 0.0
        self.fit = s.text("fit") if s.has("fit") else "stretch"
        self.memory_only = s.has("memory_only") and s["memory_only"].value is True
        self.adapt_threads = s.has("adapt_threads") and s["adapt_threads"].value is True
        self.simd_target = s.text("simd_target") if s.has("simd_target") else ""
        self.records = []
        for r in doc.array("records"):
            rec = {"method": r.text("method"), "kind": r.text("kind"), "width": r.whole("width"),
                   "height": r.whole("height"), "num_disparities": r.whole("num_disparities"),
                   "threads": r.whole("threads"), "threads_requested": r.whole("threads_requested"),
                   "frames": r.whole("frames"), "median_ms": r.num("median_ms"), "p95_ms": r.num("p95_ms"),
                   "fps": r.num("fps"), "ratio": r.num("ratio_to_stereobm", nullable=True),
                   "backend": r.text("backend") if rec_is_mctstereo(r) else None, "stages": None,
                   "warmup_frames": r.whole("warmup_frames"),
                   "frames_alone": r.whole("frames_alone") if r.has("frames_alone") else None,
                   # Runs from before bench measured them have neither.
                   "mean_ms": r.num("mean_ms") if r.has("mean_ms") else None,
                   "cpu_cores": r.num("cpu_cores") if r.has("cpu_cores") else None}
            if rec["backend"] == "opencl":  # per-kernel device times, upload, download and frame
                st = r.obj("stage_median_ms")
                rec["stages"] = {k: st.num(k) for k in st.keys()}
            elif rec["backend"] is not None:
                st = r.obj("stage_median_ms")
                # Runs from before the weighted median had a slot of its own hold it in refine.
                rec["stages"] = {k: st.num(k) if k != "wmedian" or st.has(k) else 0.0 for k in STAGES + ["frame"]}
            rec["work"] = [{"width": w.whole("width"), "height": w.whole("height"), "views": w.whole("views"),
                            "candidates": w.num("candidates")} for w in r.array("level_work")] \
                if r.has("level_work") else []
            self.records.append(rec)
        m = doc.obj("memory")
        self.peak_resident = m.num("peak_resident_bytes")
        self.memory = []
        for r in m.array("records"):
            self.memory.append({"method": r.text("method"), "width": r.whole("width"), "height": r.whole("height"),
                                "num_disparities": r.whole("num_disparities"), "backend": r.text("backend"),
                                "threads": r.whole("threads"), "estimate": r.num("estimate_memory_bytes"),
                                "peak": r.num("peak_resident_bytes"), "baseline": r.num("baseline_resident_bytes"),
                                "peak_measure": r.text("peak_measure")})
        self.opencl_device = s.text("opencl_device") if s.has("opencl_device") else None
        self.skipped = [(k.text("method"), k.text("size"), k.value.get("num_disparities"), k.text("reason"))
                        for k in doc.array("skipped")]

    def find(self, method, size, disparities, threads_requested, backend="cpu"):
        """The record of a method in one group; OpenCV records have no backend."""
        for r in self.records:
            if (r["method"] == method and (r["width"], r["height"]) == size and r["num_disparities"] ==
                    disparities_of(r, disparities) and r["threads_requested"] == threads_requested and
                    (r["backend"] is None or r["backend"] == backend)):
                return r
        return None

    def methods(self):
        """Peers first, then the presets in the order of the settings."""
        peers = sorted({r["method"] for r in self.records if r["backend"] is None}, key=peer_key)
        return peers + [p for p in self.presets if any(r["method"] == p for r in self.records)]

    def command(self, file_name):
        if self.settings["command_line"]:
            return self.settings["command_line"]
        parts = ["build/release/apps/mctstereo bench", f"--image-left {self.images[0]}", f"--image-right {self.images[1]}",
                 "--sizes " + ",".join(size_text(s) for s in self.sizes),
                 "--num-disparities " + ",".join(str(d) for d in self.disparities),
                 "--threads " + ",".join(str(t) for t in self.thread_settings),
                 "--backend " + ",".join(self.backends), "--presets " + ",".join(self.presets),
                 f"--frames {number(self.flags['min_frames'])}", f"--warmup {number(self.flags['warmup_frames'])}",
                 f"--min-time {number(self.flags['min_time_s'])}"]
        if self.memory_only:
            parts = parts[:8] + ["--memory-only"]
        if self.fit == "tile":
            parts.append("--fit tile")
        if self.load_threads > 0:
            parts.append(f"--load {self.load_threads}")
        parts.append(f"--json docs/results/{file_name}")
        return " ".join(parts)


def rec_is_mctstereo(node):
    return node.text("kind") == "mctstereo"


def disparities_of(record, requested):
    # OpenCV searches the range rounded up to a multiple of 16.
    return requested if record["backend"] is not None else -(-requested // 16) * 16


def parse_size(text, file, where):
    try:
        w, h = text.lower().split("x")
        return int(w), int(h)
    except (ValueError, AttributeError):
        raise InputError(f"{file}: '{where}' holds '{text}', not a size WIDTHxHEIGHT") from None


# --- Formatting ------------------------------------------------------------------------------------


def scene_key(name):
    low = name.lower()
    return (SCENE_ORDER.index(low) if low in SCENE_ORDER else len(SCENE_ORDER), low)


def peer_key(name):
    order = [STEREOBM, STEREOSGBM]
    return (order.index(name) if name in order else len(order), name)


def scene_title(name):
    return name[:1].upper() + name[1:]


def method_name(name):
    return PEER_NAMES.get(name, f"`{name}`" if not name.startswith("opencv-") else name)


def method_plain(name):
    return PEER_NAMES.get(name, name)


def size_text(size):
    return f"{size[0]}x{size[1]}"


def number(v):
    return str(int(v)) if v == int(v) else f"{v:g}"


def pct(v):
    return "-" if v is None else f"{v:.2f}"


def density(v):
    return "-" if v is None else f"{v:.1f}"


def ms(v):
    if v is None:
        return "-"
    return f"{v:.2f}" if v < 100 else f"{v:.1f}" if v < 1000 else f"{v:.0f}"


def fps(v):
    return "-" if v is None else f"{v:.1f}" if v < 1000 else f"{v:.0f}"


def ratio(v):
    return "-" if v is None else f"{v:.2f}"


def mib(v):
    return "-" if v is None else f"{v / 1048576:.1f}"


def wrapped(part, width=110):
    """Prose wrapped for reading as plain text; tables, code, headings and images as they are."""
    if part.startswith(("|", "```", "#", "![")):
        return part
    lines = []
    for line in part.split("\n"):
        bullet = line.startswith("- ")
        lines += textwrap.wrap(line, width=width, subsequent_indent="  " if bullet else "", break_long_words=False,
                               break_on_hyphens=False) or [""]
    return "\n".join(lines)


def table(header, rows, align=None):
    align = align or ["---"] + ["---:"] * (len(header) - 1)
    lines = ["| " + " | ".join(header) + " |", "| " + " | ".join(align) + " |"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def code(command):
    return f"```\n{command}\n```"


def machine_line(settings, file, with_threads=True):
    """The machine and build of one run; eval runs use one thread count, bench runs name theirs per table row."""
    s, name = settings, os.path.basename(file)
    threads = f", {s['threads']} thread{'s' if s['threads'] != 1 else ''}" if with_threads else ""
    return (f"Machine: {s['cpu_model']}, {s['cores_online']} cores, SIMD target {s['simd_target']}"
            f"{threads}; {s['compiler']}, OpenCV {s['opencv_version']}, mctstereo "
            f"{s['mctstereo_version']}; {s['date']} ([{name}]({{results}}/{name})).")


def join_words(items):
    items = list(items)
    if len(items) <= 1:
        return "".join(items)
    return ", ".join(items[:-1]) + " and " + items[-1]


def pick(values, preferred):
    return preferred if preferred in values else values[0]


# --- Figures ---------------------------------------------------------------------------------------


def png_bytes(fig, palette=False):
    """The figure as PNG bytes; palette: reduced to PREVIEW_COLOURS colours (previews: a third of the size)."""
    buffer = io.BytesIO()
    # No Software/date chunk: the same data gives the same bytes.
    fig.savefig(buffer, format="png", dpi=100, metadata={"Software": None})
    plt.close(fig)
    if not palette:
        return buffer.getvalue()
    from PIL import Image  # Pillow: a dependency of matplotlib

    image = Image.open(io.BytesIO(buffer.getvalue())).convert("RGB")
    image = image.quantize(colors=PREVIEW_COLOURS, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    out = io.BytesIO()
    image.save(out, format="PNG", optimize=True)
    return out.getvalue()


def plot_quality_vs_fps(points, group_text):
    fig, ax = plt.subplots(figsize=(7.0, 4.6))
    xs = [p[1] for p in points]
    ys = [p[2] for p in points]
    for name, frames_per_second, percent_bad, is_peer in points:
        ax.scatter([frames_per_second], [percent_bad], marker="s" if is_peer else "o", s=46,
                   color="tab:red" if is_peer else "tab:blue", zorder=3)
    ax.set_xscale("log")
    ax.set_xlim(min(xs) / 1.6, max(xs) * 3.0)
    span = max(max(ys) - min(ys), 1.0)
    ax.set_ylim(min(ys) - 0.08 * span, max(ys) + 0.12 * span)
    ax.set_xlabel(f"frames per second, {group_text} (log)")
    ax.set_ylabel("average percent bad, Middlebury 2003")
    ax.set_title("Quality against frame rate: circles mctstereo presets, squares OpenCV\n"
                 "(lower right is better)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    place_labels(ax, [(x, y, method_plain(name)) for name, x, y, _ in points])
    return png_bytes(fig)


def place_labels(ax, labelled_points, fontsize=8.5):
    """Labels beside their points, each moved to the first free spot of a few (in display pixels)."""
    to_pixels = ax.transData.transform
    char_px, height_px = 0.62 * fontsize * 100 / 72, fontsize * 100 / 72 * 1.2
    markers = [tuple(to_pixels((x, y))) for x, y, _ in labelled_points]
    taken = [(mx - 6, my - 6, mx + 6, my + 6) for mx, my in markers]

    def free(box):
        return all(box[2] <= t[0] or box[0] >= t[2] or box[3] <= t[1] or box[1] >= t[3] for t in taken)

    order = sorted(range(len(labelled_points)), key=lambda i: (markers[i][0], markers[i][1]))
    for i in order:
        x, y, text = labelled_points[i]
        mx, my = markers[i]
        w = char_px * len(text)
        candidates = [(7, 2), (7, -height_px - 2), (7, height_px - 2), (-7 - w, 2), (-7 - w, -height_px - 2),
                      (7, -2 * height_px - 2), (7, 2 * height_px - 2), (-w / 2, 8), (-w / 2, -height_px - 8)]
        dx, dy = candidates[0]
        for cx, cy in candidates:
            if free((mx + cx, my + cy, mx + cx + w, my + cy + height_px)):
                dx, dy = cx, cy
                break
        taken.append((mx + dx, my + dy, mx + dx + w, my + dy + height_px))
        ax.annotate(text, (x, y), textcoords="offset pixels", xytext=(dx, dy), fontsize=fontsize, ha="left",
                    va="bottom")


def plot_fps_vs_resolution(series, sizes, group_text):
    fig, ax = plt.subplots(figsize=(7.0, 4.6))
    markers = "os^vD<>p*h"
    for i, (name, points) in enumerate(series):
        xs = [w * h / 1e6 for (w, h), _ in points]
        ys = [v for _, v in points]
        is_peer = name.startswith("opencv-")
        ax.plot(xs, ys, marker=markers[i % len(markers)], linestyle="--" if is_peer else "-",
                label=method_plain(name), linewidth=1.4, markersize=5)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ticks = sorted({w * h / 1e6 for w, h in sizes})
    ax.set_xticks(ticks)
    labels = {}
    for w, h in sizes:
        labels.setdefault(w * h / 1e6, []).append(f"{w}x{h}")
    ax.set_xticklabels(["\n".join(labels[t]) for t in ticks], fontsize=7.5, rotation=35, ha="right")
    ax.minorticks_off()
    ax.set_xlabel("frame size (megapixels, log)")
    ax.set_ylabel("frames per second (log)")
    ax.set_title(f"Frame rate against resolution, {group_text}", fontsize=11)
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=8.5)
    fig.tight_layout()
    return png_bytes(fig)


def read_scene_txt(folder):
    keys = {}
    path = os.path.join(folder, "scene.txt")
    with open(path, encoding="utf-8") as f:
        for line in f:
            line = line.strip()
            if line and not line.startswith("#") and "=" in line:
                k, v = line.split("=", 1)
                keys[k.strip()] = v.strip()
    return keys


def read_pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        if kind not in (b"Pf", b"PF"):
            raise ValueError(f"{path}: not a PFM file")
        dims = f.readline().split()
        while not dims:
            dims = f.readline().split()
        width, height = int(dims[0]), int(dims[1])
        scale = float(f.readline().strip())
        channels = 3 if kind == b"PF" else 1
        data = np.frombuffer(f.read(width * height * channels * 4), dtype="<f4" if scale < 0 else ">f4")
    image = data.reshape(height, width, channels)[..., 0]
    return np.flipud(image).astype(np.float64)  # PFM rows run bottom to top


def read_png_values(path):
    """Integer pixel values of an 8- or 16-bit (or palette) PNG, channel 0."""
    with open(path, "rb") as f:
        header = f.read(26)
    if header[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG file")
    depth, colour_type = header[24], header[25]
    image = mpimg.imread(path)  # floats in [0, 1]
    if image.ndim == 3:
        image = image[..., 0]
    # Palette images come back as the palette's colours; others as value / (2^depth - 1).
    full_scale = 65535.0 if depth == 16 and colour_type != 3 else 255.0
    return np.rint(image.astype(np.float64) * full_scale)


def ground_truth_colours(folder, keys, dmin, dmax):
    """The left view's ground truth coloured as `mctstereo match --color` colours a map."""
    path = os.path.join(folder, keys["gt"])
    scale = float(keys.get("gt_scale", "1"))
    if path.lower().endswith(".pfm"):
        raw = read_pfm(path)
        unknown = ~np.isfinite(raw)
        disparity = np.where(unknown, 0.0, raw) / scale
    else:
        raw = read_png_values(path)
        unknown = raw == float(keys.get("gt_invalid", "0"))
        disparity = raw / scale
    span = max(dmax - dmin, 1)
    level = np.clip(np.rint(255.0 * (disparity - dmin) / span), 0, 255).astype(np.int64)
    lut = matplotlib.colormaps["turbo"].resampled(256)(np.arange(256))[:, :3]
    colours = lut[level]
    colours[unknown] = 0.0
    return colours


def downscaled(image, step):
    return image[::step, ::step]


def compose_previews(eval_run, previews_dir, set_label):
    """One PNG: a row per scene (left image, ground truth, the preview methods).

    Returns (bytes, None), or (None, why) when there is nothing to show or a scene cannot be read."""
    methods = [m for m in PREVIEW_METHODS if m in eval_run.method_order]
    rows = []
    for scene in eval_run.scenes:
        folder = os.path.normpath(os.path.join(REPO_ROOT, scene["path"]))  # eval runs from the repository root
        panels = {}
        for m in methods:
            path = os.path.join(previews_dir, f"{file_name_part(scene['name'])}_{file_name_part(m)}_disparity.png")
            if os.path.isfile(path):
                panels[m] = mpimg.imread(path)[..., :3]
        if not panels:
            continue
        try:
            keys = read_scene_txt(folder)
            left = mpimg.imread(os.path.join(folder, keys["left"]))
            dmin = scene["min_disparity"]
            truth = ground_truth_colours(folder, keys, dmin, dmin + scene["num_disparities"] - 1)
        except (OSError, KeyError, ValueError) as error:
            return None, f"cannot read the images of scene '{scene['name']}' ({folder}): {error}"
        rows.append((scene, left, truth, panels))
    if not rows:
        return None, f"no previews in {previews_dir}"
    titles = ["left image", "ground truth"] + [method_plain(m) for m in methods]
    # Every panel is placed by hand (inches), so that the figure has no slack around the images.
    panel, gap, left_margin, top_margin = PREVIEW_PANEL_WIDTH / 100.0, 0.05, 0.3, 0.42
    heights = [panel * r[0]["height"] / r[0]["width"] for r in rows]
    width_in = left_margin + len(titles) * panel + (len(titles) - 1) * gap
    height_in = top_margin + sum(heights) + (len(rows) - 1) * gap
    fig = plt.figure(figsize=(width_in, height_in))
    fig.text(0.05 / width_in, 1 - 0.05 / height_in, set_label, fontsize=9, ha="left", va="top")
    top = height_in - top_margin
    for (scene, left, truth, panels), row_height in zip(rows, heights):
        step = max(1, math.ceil(scene["width"] / PREVIEW_PANEL_WIDTH))
        images = [left, truth] + [panels.get(m) for m in methods]
        for j, image in enumerate(images):
            x = left_margin + j * (panel + gap)
            ax = fig.add_axes([x / width_in, (top - row_height) / height_in, panel / width_in, row_height / height_in])
            ax.set_xticks([])
            ax.set_yticks([])
            if image is None:
                ax.text(0.5, 0.5, "not saved", ha="center", va="center", fontsize=8, transform=ax.transAxes)
            else:
                small = downscaled(image, step)
                ax.imshow(small, cmap="gray" if small.ndim == 2 else None, interpolation="nearest", aspect="auto")
            if top == height_in - top_margin:
                ax.set_title(titles[j], fontsize=8.5, pad=3)
            if j == 0:
                ax.set_ylabel(scene_title(scene["name"]), fontsize=8.5, labelpad=3)
        top -= row_height + gap
    return png_bytes(fig, palette=True), None


def file_name_part(name):
    # The file names of eval --save: every character but alphanumerics, '-', '_' and '.' becomes '_'.
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name)


# --- The report ------------------------------------------------------------------------------------


class Report:
    def __init__(self, results_dir, images_dir, output, previews_dir):
        self.results_dir, self.images_dir, self.output, self.previews_dir = (
            results_dir, images_dir, output, previews_dir)
        out_dir = os.path.dirname(os.path.abspath(output))
        self.results_link = os.path.relpath(os.path.abspath(results_dir), out_dir).replace(os.sep, "/")
        self.images_link = os.path.relpath(os.path.abspath(images_dir), out_dir).replace(os.sep, "/")
        self.parts = []
        self.images = {}  # file name -> bytes
        self.losses = []  # (section, line) for "Where mctstereo loses"

    def add(self, text):
        self.parts.append(text.replace("{results}", self.results_link))

    def image(self, name, data, alt):
        self.images[name] = data
        self.add(f"![{alt}]({self.images_link}/{name})")

    def markdown(self):
        return "\n\n".join(wrapped(p.strip("\n")) for p in self.parts) + "\n"


def header(report, runs):
    report.add("# Results")
    report.add(
        "Quality on Middlebury and speed against OpenCV, measured with the `mctstereo` command line. This file is "
        "generated: `bash scripts/measure_results.sh [path/to/mctstereo]` runs every measurement below (it writes the "
        "JSON files in [results/]({results}/) and the previews, then calls the generator), and "
        "`python3 scripts/make_results.py` alone rebuilds this file and its figures from those JSON files "
        "(python3 with matplotlib; on Debian /usr/bin/python3 with python3-matplotlib). Edit the script, not this "
        "file. Every table names the command that made it and the machine it ran on.")
    machines = sorted({(s["cpu_model"], s["cores_online"], s["simd_target"]) for _, s in runs})
    if len(machines) == 1:
        cpu, cores, simd = machines[0]
        report.add(f"**Machine.** Every run below: {cpu}, {cores} cores online, Highway SIMD target {simd}. The "
                   "machine may be shared: the benchmarks take medians of many frames, and each ratio compares "
                   "methods timed in the same run, on the same frames.")
    else:
        report.add("**Machines.** The runs below did not all run on one machine: see the table; compare times "
                   "only within one file.")
    rows = [[f"[{name}]({{results}}/{name})", s["date"], s["cpu_model"], s["cores_online"], s["simd_target"],
             s["threads"], s["compiler"], s["build_type"], s["opencv_version"], s["mctstereo_version"]]
            for name, s in runs]
    report.add(table(["file", "date (UTC)", "CPU", "cores", "SIMD", "threads", "compiler", "build", "OpenCV",
                      "mctstereo"], rows, ["---"] * 10))


def region_cells(scene, entry):
    if entry.get("skipped"):
        return "skipped"
    return " / ".join(pct(entry[r]) for r in scene["regions"])


def quality_2003(report, ev):
    report.add("## Quality: Middlebury 2003 (v2 evaluation set)")
    report.add(
        f"Bad pixels (|d - ground truth| > {number(ev.threshold)} px, pixels without a disparity counted as bad) in "
        "the non-occluded (nonocc), all and near-discontinuity (disc) regions; each scene searched over its own "
        "range; colour input converted to luma by the library, OpenCV on gray frames (StereoBM block 9, StereoSGBM "
        "block 5 3-way, the range rounded up to a multiple of 16). density: percent of pixels with a disparity; "
        "ms: frame time on the scenes (median of the repeated frames, mean over the scenes), from the same run.")
    report.add(code(ev.settings["command_line"] or "(command line not recorded)"))
    report.add(machine_line(ev.settings, ev.file))
    numbers = sum(len(s["regions"]) for s in ev.scenes)
    header_row = ["method"] + [f"{scene_title(s['name'])} {' / '.join(s['regions'])}" for s in ev.scenes] + [
        f"average of the {numbers}", "density %", "ms"]
    best = min((ev.methods[m]["average_percent_bad"] for m in ev.method_order
                if ev.methods[m]["average_percent_bad"] is not None), default=None)
    rows = []
    for m in ev.method_order:
        summary = ev.methods[m]
        avg = summary["average_percent_bad"]
        cells = [region_cells(s, s["methods"][m]) for s in ev.scenes]
        avg_text = f"**{pct(avg)}**" if avg is not None and avg == best else pct(avg)
        rows.append([method_name(m)] + cells + [avg_text, density(summary["average"]["density"]),
                                                ms(summary["average"]["ms"])])
    report.add(table(header_row, rows))
    below = [f"{method_name(m)} {ev.methods[m]['average']['density']:.1f}" for m in ev.method_order
             if ev.methods[m]["average"]["density"] is not None and ev.methods[m]["average"]["density"] < 99.995]
    full = [method_name(m) for m in ev.method_order
            if ev.methods[m]["average"]["density"] is not None and ev.methods[m]["average"]["density"] >= 99.995]
    if full:
        report.add(f"Density is 100 % for {join_words(full)}" + (f"; below it: {join_words(below)} % (pixels "
                   "without a disparity count as bad above)." if below else "."))
    report.add("Not from this run, for comparison (averages of the same 12 numbers): " + "; ".join(
        f"{name} {value:.1f} % ({how})" for name, value, how in NOT_FROM_THIS_RUN) + ".")
    targets_2003(report, ev)

    thesis = [(k, label) for k, label in THESIS_VARIANTS if k in ev.methods and k in ev.presets]
    if thesis:
        report.add("### The thesis variants (the thesis's table layout)")
        report.add("The same run, in the layout of the thesis's Middlebury table: "
                   + join_words(f"`{k}` = {label}" for k, label in thesis) + ".")
        head = ["variant"]
        for s in ev.scenes:
            for i, r in enumerate(s["regions"]):
                head.append(f"{scene_title(s['name'])} {r}" if i == 0 else r)
        head.append("average")
        rows = []
        for k, label in thesis:
            row = [label]
            for s in ev.scenes:
                e = s["methods"][k]
                row += ["skipped" if e.get("skipped") else pct(e[r]) for r in s["regions"]]
            rows.append(row + [pct(ev.methods[k]["average_percent_bad"])])
        report.add(table(head, rows))
        report.add("Same command and run as the first table.")

    report.add("### Middlebury v3 and KITTI D1 (mean over the scenes)")
    report.add("bad N: percent of nonocc pixels off by more than N px (no disparity = bad); avgerr and rms: mean and "
               "root-mean-square error in px over the nonocc pixels that have a disparity (so a method that leaves "
               "hard pixels empty is not charged for them here: read them with invalid); invalid: percent of nonocc "
               "pixels without a disparity; D1: percent off by more than 3 px and 5 % (nonocc, and all pixels).")
    keys = [("bad_0_5", "bad 0.5"), ("bad_1", "bad 1"), ("bad_2", "bad 2"), ("bad_4", "bad 4"),
            ("avgerr", "avgerr px"), ("rms", "rms px"), ("invalid", "invalid %"), ("d1", "D1 nonocc"),
            ("d1_all", "D1 all")]
    rows = [[method_name(m)] + [pct(ev.methods[m]["average"][k]) for k, _ in keys] for m in ev.method_order]
    report.add(table(["method"] + [label for _, label in keys], rows))
    report.add("Same command and run as the table above.")
    sparsification_section(report, ev, "Middlebury 2003")
    preset_parameters(report, ev)
    losses_quality(report, ev, "Middlebury 2003", keys)


def targets_2003(report, ev):
    scored = [p for p in ev.presets if ev.methods[p]["average_percent_bad"] is not None]
    if not scored:
        return
    best = min(scored, key=lambda p: ev.methods[p]["average_percent_bad"])
    best_value = ev.methods[best]["average_percent_bad"]
    met = best_value < TARGET_BEST_PRESET_PERCENT_BAD
    text = (f"Against the targets: the best preset, `{best}` at {best_value:.2f} %, "
            f"{'meets' if met else 'misses'} the {TARGET_BEST_PRESET_PERCENT_BAD} % target and is "
            f"{'below' if best_value < NOT_FROM_THIS_RUN[0][1] else 'not below'} RTCensus's published "
            f"{NOT_FROM_THIS_RUN[0][1]} %.")
    multi = ev.presets_with(lambda p: p.get("pyramid_levels", 1) > 1)
    if multi:
        over = [p for p in multi if ev.methods[p]["average_percent_bad"] is None or
                ev.methods[p]["average_percent_bad"] >= TARGET_MULTI_RESOLUTION_PERCENT_BAD]
        listing = join_words(f"`{p}` {pct(ev.methods[p]['average_percent_bad'])}" for p in multi)
        if over:
            text += (f" The multi-resolution presets should stay under "
                     f"{number(TARGET_MULTI_RESOLUTION_PERCENT_BAD)} %: {listing}; missed by "
                     f"{join_words(f'`{p}`' for p in over)}.")
            over_text = join_words(f"`{p}` {pct(ev.methods[p]['average_percent_bad'])}" for p in over)
            report.losses.append(("Targets", f"Multi-resolution presets at or over "
                                  f"{number(TARGET_MULTI_RESOLUTION_PERCENT_BAD)} % on Middlebury 2003: {over_text}."))
        else:
            text += (f" Every multi-resolution preset is under {number(TARGET_MULTI_RESOLUTION_PERCENT_BAD)} % "
                     f"({listing}).")
    if not met:
        report.losses.append(("Targets", f"The best preset `{best}` ({best_value:.2f} %) misses the "
                              f"{TARGET_BEST_PRESET_PERCENT_BAD} % target on Middlebury 2003."))
    sgm = [(p, t) for p, t in TARGET_SGM_PERCENT_BAD.items() if p in scored]
    if sgm:
        parts = []
        for p, t in sgm:
            v = ev.methods[p]["average_percent_bad"]
            parts.append(f"`{p}` {v:.2f} % (target {number(t)} %: {'met' if v <= t else 'missed'})")
            if v > t:
                report.losses.append(("Targets", f"Band SGM `{p}` at {v:.2f} % misses its {number(t)} % target on "
                                      f"Middlebury 2003."))
        text += " Band SGM: " + join_words(parts) + "."
    report.add(text)


PARAMETER_LABELS = [
    ("census", "local transform"), ("census_window", "census window"), ("mct_kernel", "MCT mean (3x3 kernel)"),
    ("shd_window", "SHD window"), ("coarse_shd_window", "SHD window, coarse levels"),
    ("pyramid_levels", "pyramid levels"), ("search_radius", "search radius (coarse to fine)"),
    ("refine_all_levels", "refine every level"), ("subpixel", "sub-pixel"), ("median_size", "median"),
    ("lr_check", "left-right check"), ("lr_threshold", "left-right threshold px"),
    ("speckle_size", "speckle removal (px)"), ("uniqueness_ratio", "uniqueness %"), ("fill", "fill"),
    ("post_median_size", "median after filling"),
    ("weighted_median", "colour-weighted median (then 3x3 instead of the median after filling)"),
    ("wm_radius", "weighted median radius px"), ("wm_step", "weighted median step px"),
    ("wm_sigma", "weighted median sigma"), ("working_scale", "working scale"),
]


def preset_parameters(report, ev):
    presets = [p for p in ev.presets if ev.methods[p]["parameters"]]
    if not presets:
        return
    report.add("### What the presets are made of")
    report.add("Every parameter of each preset as the run above used it (its `parameters` in the JSON; the range "
               "is each scene's own). Together with the first table this is what a change of preset buys: the "
               "single-level presets search the full range at full resolution, the multi-resolution ones search "
               "the full range only at the coarsest level and then a radius around the coarser level's answer.")

    def value(v):
        if isinstance(v, bool):
            return "yes" if v else "no"
        if isinstance(v, float):
            return number(v)
        return "-" if v is None else str(v)

    keys = [k for k, _ in PARAMETER_LABELS]
    extra = sorted({k for p in presets for k in ev.methods[p]["parameters"]} - set(keys) -
                   {"min_disparity", "num_disparities"})
    labels = dict(PARAMETER_LABELS)
    rows = []
    for k in keys + extra:
        if not any(k in ev.methods[p]["parameters"] for p in presets):
            continue
        rows.append([labels.get(k, k)] + [value(ev.methods[p]["parameters"].get(k)) for p in presets])
    report.add(table(["parameter"] + [f"`{p}`" for p in presets], rows, ["---"] + ["---"] * len(presets)))


def losses_quality(report, ev, set_name, metric_keys):
    """Where a peer scores better than a preset: per scene and region, and per averaged metric."""
    for peer in ev.peers:
        wins = []
        for s in ev.scenes:
            pe = s["methods"][peer]
            if pe.get("skipped"):
                continue
            for r in s["regions"]:
                beaten = [p for p in ev.presets if not s["methods"][p].get("skipped") and
                          pe[r] is not None and s["methods"][p][r] is not None and pe[r] < s["methods"][p][r]]
                if beaten:
                    who = ("every preset" if len(beaten) == len(ev.presets) else join_words(f"`{p}`" for p in beaten))
                    wins.append(f"{scene_title(s['name'])} {r} ({pct(pe[r])} against "
                                f"{pct(min(s['methods'][p][r] for p in beaten))} to "
                                f"{pct(max(s['methods'][p][r] for p in beaten))}: better than {who})")
        if wins:
            report.losses.append((f"Quality, {set_name}", f"{method_plain(peer)} has fewer bad pixels than presets on "
                                  + "; ".join(wins) + "."))
        metric_wins = []
        for k, label in metric_keys:
            v = ev.methods[peer]["average"].get(k)
            if v is None:
                continue
            beaten = [p for p in ev.presets if ev.methods[p]["average"].get(k) is not None and
                      v < ev.methods[p]["average"][k]]
            if beaten:
                who = "every preset" if len(beaten) == len(ev.presets) else join_words(f"`{p}`" for p in beaten)
                plain_label = label.replace(" px", "").replace(" %", "")
                metric_wins.append(f"{plain_label} {pct(v)} (better than {who})")
        if metric_wins:
            caveat = ""
            invalid = ev.methods[peer]["average"].get("invalid")
            if any(k in ("avgerr", "rms") for k, _ in metric_keys) and invalid:
                caveat = (f" (avgerr and rms leave out the {pct(invalid)} % of nonocc pixels {method_plain(peer)} "
                          "gives no disparity)")
            report.losses.append((f"Quality, {set_name}", f"{method_plain(peer)} on the averaged v3/D1 metrics: "
                                  + "; ".join(metric_wins) + caveat + "."))


def sparsification_section(report, ev, set_name):
    """Bad pixels of the most confident fractions of the pixels, per method, mean over the scenes."""
    with_curve = [m for m in ev.method_order
                  if all(s["methods"][m].get("sparsification") for s in ev.scenes)]
    if not with_curve:
        return
    fractions = [f for f, _ in ev.scenes[0]["methods"][with_curve[0]]["sparsification"]]
    report.add(f"### Confidence: sparsification on {set_name}")
    report.add("`Matcher::confidence()` (docs/PIPELINE.md, \"Confidence\") orders the pixels that have ground truth "
               "('all' region); each column gives the percent bad (> "
               f"{number(ev.threshold)} px) of the most confident fraction of them, mean over the scenes. A "
               "confidence that ranks well leaves few errors in its confident part; the last column over the first "
               "is the share of the errors the most confident half keeps. Box presets make the map with "
               "`MatcherOptions::compute_confidence`, as `eval` does; OpenCV's matchers have none.")
    rows = []
    for m in with_curve:
        curve = [sum(dict(s["methods"][m]["sparsification"])[f] for s in ev.scenes) / len(ev.scenes)
                 for f in fractions]
        share = curve[-1] / curve[0] if curve[0] else float("nan")
        rows.append([method_name(m)] + [pct(v) for v in curve] + [f"{share:.2f}"])
    report.add(table(["method"] + [f"{round(100 * f)} %" for f in fractions] + ["half / all"], rows))
    report.add("Same command and run as the first table of this section.")


def quality_2005(report, ev):
    report.add("## Quality: Middlebury 2005/2006")
    sources = sorted({s["mask_source"] for s in ev.scenes})
    scenes_text = join_words(f"{scene_title(s['name'])} ({s['width']}x{s['height']}, disparities "
                             f"{s['min_disparity']}..{s['min_disparity'] + s['num_disparities'] - 1})"
                             for s in ev.scenes)
    text = f"Scenes: {scenes_text}. "
    if "derived-lr-check" in sources:
        text += ("These sets have no official masks: nonocc is derived by the left-right check of the two views' "
                 "ground truths (a left pixel is non-occluded when the right ground truth at x - round(d) is known "
                 "and within 1 px of d), all is every pixel with ground truth, and there is no disc region. ")
    text += (f"Bad pixels > {number(ev.threshold)} px as above; the numbers are not comparable with published "
             "Middlebury 2005/2006 tables, which use other masks.")
    report.add(text)
    report.add(code(ev.settings["command_line"] or "(command line not recorded)"))
    report.add(machine_line(ev.settings, ev.file))
    numbers = sum(len(s["regions"]) for s in ev.scenes)
    head = ["method"] + [f"{scene_title(s['name'])} {' / '.join(s['regions'])}" for s in ev.scenes] + [
        f"average of the {numbers}", "D1 nonocc", "density %", "ms"]
    rows = []
    for m in ev.method_order:
        a = ev.methods[m]["average"]
        rows.append([method_name(m)] + [region_cells(s, s["methods"][m]) for s in ev.scenes] +
                    [pct(ev.methods[m]["average_percent_bad"]), pct(a["d1"]), density(a["density"]), ms(a["ms"])])
    report.add(table(head, rows))
    sparsification_section(report, ev, "Middlebury 2005/2006")
    losses_quality(report, ev, "Middlebury 2005/2006", [("bad_0_5", "bad 0.5"), ("bad_2", "bad 2"),
                                                        ("avgerr", "avgerr"), ("rms", "rms"), ("d1", "D1 nonocc")])


def exposure_study(report, ev):
    r = ev.radiometric
    report.add("## Exposure study (radiometric changes, Middlebury 2003)")
    report.add(
        "The right image alone is changed (gain, bias, gamma, vignetting, Gaussian noise; noise seeded by "
        f"{r['seed']}) and every method scored again. A cell is the {r['headline']}; the first row is the unchanged "
        "pair.")
    report.add(code(ev.settings["command_line"] or "(command line not recorded)"))
    report.add(machine_line(ev.settings, ev.file))
    methods = ev.method_order
    head = ["step"] + [PEER_SHORT.get(m, m) for m in methods]
    rows = []
    for st in r["steps"]:
        values = [st["scores"][m] for m in methods]
        best = min((v for v in values if v is not None), default=None)
        rows.append([st["step"]] + [f"**{pct(v)}**" if v is not None and v == best else pct(v) for v in values])
    report.add(table(head, rows))
    report.add("Bold: the best method of the step. Per method, over the changed steps (degradation = score minus "
               "the method's unchanged score, in points of percent bad):")
    rows = []
    for m in methods:
        s = r["summary"].get(m)
        if s is None:
            raise InputError(f"{ev.file}: 'radiometric.summary' has no entry for method '{m}'")
        rows.append([method_name(m), s["census"] or "-", pct(s["baseline"]), pct(s["mean"]),
                     f"{pct(s['worst'])} ({s['worst_step'] or '-'})", pct(s["mean_degradation"]),
                     pct(s["worst_degradation"])])
    report.add(table(["method", "census", "unchanged", "mean", "worst (step)", "mean degradation",
                      "worst degradation"], rows))
    kinds = list(r["by_change"].keys())
    censuses = sorted({c for k in kinds for c in r["by_change"][k]})
    if kinds and censuses:
        report.add("Mean degradation of the presets of each census transform, per kind of change:")
        report.add(table(["change"] + [f"{c.upper()} presets" for c in censuses],
                         [[k] + [pct(r["by_change"][k].get(c)) for c in censuses] for k in kinds]))
    report.add(f"**CT against MCT.** {r['conclusion']}")
    worst = max((m for m in methods if r["summary"][m]["worst_degradation"] is not None),
                key=lambda m: r["summary"][m]["worst_degradation"], default=None)
    if worst:
        s = r["summary"][worst]
        report.add(f"The largest loss is {method_name(worst)}'s: +{pct(s['worst_degradation'])} points at "
                   f"{s['worst_step']}.")
    # Losses: steps where a peer beats a preset, and peers that degrade less than a preset.
    for peer in ev.peers:
        steps = []
        for st in r["steps"]:
            v = st["scores"][peer]
            beaten = [p for p in ev.presets if v is not None and st["scores"][p] is not None and v < st["scores"][p]]
            if beaten:
                steps.append(f"{st['step']} (better than {join_words(f'`{p}`' for p in beaten)})")
        if steps:
            report.losses.append(("Exposure study", f"{method_plain(peer)} scores better than presets at "
                                  + "; ".join(steps) + "."))
        deg = r["summary"][peer]["mean_degradation"]
        softer = [p for p in ev.presets if deg is not None and r["summary"][p]["mean_degradation"] is not None and
                  deg < r["summary"][p]["mean_degradation"]]
        if softer:
            report.losses.append(("Exposure study", f"{method_plain(peer)} degrades less on average ({pct(deg)} "
                                  f"points) than {join_words(f'`{p}`' for p in softer)}."))


def bench_group_text(size, disparities, threads):
    return f"{size_text(size)}, {disparities} disparities, {threads} thread{'s' if threads != 1 else ''}"


def headline_ratios(records):
    """The target ratios of one run: realtime and balanced x StereoBM, quality x StereoSGBM (None: not timed)."""
    sgbm = records.get(STEREOSGBM)
    q = records.get("quality")
    return {"realtime": records["realtime"]["ratio"] if "realtime" in records else None,
            "balanced": records["balanced"]["ratio"] if "balanced" in records else None,
            "quality": sgbm["median_ms"] / q["median_ms"] if q and sgbm else None}


SGBM_RATE = "StereoSGBM's frame rate"


class Repeated:
    """One target ratio over the headline run and its repeats: the median decides, the range is shown."""

    def __init__(self, values):
        self.values = sorted(v for v in values if v is not None)
        self.median = statistics.median(self.values) if self.values else None

    def text(self, unit):
        """'R x unit', and with several runs ', the median of N runs (lowest-highest)'."""
        if len(self.values) == 1:
            return f"{ratio(self.median)} x {unit}"
        return (f"{ratio(self.median)} x {unit}, the median of {len(self.values)} runs "
                f"({ratio(self.values[0])}-{ratio(self.values[-1])})")


def headline_records(bench, size, disparities, threads):
    """The records of every method of one bench file at one size, range and thread count."""
    records = {m: bench.find(m, size, disparities, threads) for m in bench.methods()}
    records = {m: r for m, r in records.items() if r is not None}
    if STEREOBM not in records:
        raise InputError(f"{bench.file}: no {STEREOBM} record at {size_text(size)}, {disparities} disparities, "
                         f"threads {threads}")
    return records


def speed_headline(report, bench, file_name, ev2003, repeats=()):
    size = pick(bench.sizes, (640, 480))
    disparities = pick(bench.disparities, 64)
    threads = pick(bench.thread_settings, 2)
    records = headline_records(bench, size, disparities, threads)
    # The targets' ratios in this run and in each repeat of it (same size, range and threads).
    runs = [headline_ratios(records)] + [headline_ratios(headline_records(run, size, disparities, threads))
                                         for run in repeats]
    target = {m: Repeated(run[m] for run in runs) for m in ("realtime", "balanced", "quality")}
    used_threads = records[STEREOBM]["threads"]
    group = bench_group_text(size, disparities, used_threads)
    report.add("## Speed against OpenCV")
    report.add(f"### Presets and peers at {group}")
    report.add(
        "The bundled Tsukuba pair resized to each size, gray; every method times the same frames in the same "
        "process: warm-up frames first, then the median (and 95th percentile) of the timed frames. x StereoBM = "
        "StereoBM's frame time over the method's (above 1: faster than StereoBM). Quality: the average percent bad "
        "on Middlebury 2003 from the evaluation above.")
    report.add(code(bench.command(file_name)))
    report.add(machine_line(bench.settings, bench.file, with_threads=False))
    sgbm = records.get(STEREOSGBM)
    rows = []
    for m, r in records.items():
        quality = ev2003.methods[m]["average_percent_bad"] if m in ev2003.methods else None
        rows.append([method_name(m), ms(r["median_ms"]), ms(r["p95_ms"]), fps(r["fps"]), ratio(r["ratio"]),
                     ratio(r["fps"] / sgbm["fps"]) if sgbm else "-", pct(quality), r["frames"]])
    report.add(table(["method", "median ms", "p95 ms", "fps", "x StereoBM", "x StereoSGBM",
                      "average % bad (2003)", "frames"], rows))
    # The targets, on the median of the runs.
    lines = []
    rt = target["realtime"]
    if rt.median is not None:
        met = rt.median >= TARGET_REALTIME_X_STEREOBM
        lines.append(f"`realtime` at least {number(TARGET_REALTIME_X_STEREOBM)} x StereoBM: "
                     f"**{'met' if met else 'missed'}**, {rt.text('StereoBM')}.")
        if not met:
            report.losses.append(("Targets", f"`realtime` reaches {rt.text('StereoBM')} at {group}, short of "
                                  f"the {number(TARGET_REALTIME_X_STEREOBM)} x target."))
    else:
        lines.append(f"`realtime` was not timed in this run: the {number(TARGET_REALTIME_X_STEREOBM)} x StereoBM "
                     "target is not checked.")
    q = target["quality"]
    if q.median is not None:
        met = q.median >= 1
        lines.append(f"`quality` at least as fast as StereoSGBM: **{'met' if met else 'missed'}**, "
                     f"{q.text(SGBM_RATE)}.")
        if not met:
            report.losses.append(("Targets", f"`quality` is slower than StereoSGBM at {group}: "
                                  f"{q.text(SGBM_RATE)}."))
    else:
        lines.append("`quality` or StereoSGBM was not timed in this run: the SGBM target is not checked.")
    b = target["balanced"]
    if b.median is not None:
        met = b.median >= TARGET_BALANCED_WM_X_STEREOBM
        lines.append(f"`balanced` with the colour-weighted median at least {number(TARGET_BALANCED_WM_X_STEREOBM)} x "
                     f"StereoBM: **{'met' if met else 'missed'}**, {b.text('StereoBM')}.")
        met = b.median >= TARGET_BALANCED_X_STEREOBM
        lines.append(f"band SGM `balanced` at least {number(TARGET_BALANCED_X_STEREOBM)} x StereoBM: "
                     f"**{'met' if met else 'missed'}**, {b.text('StereoBM')}.")
        if not met:
            report.losses.append(("Targets", f"`balanced` (band SGM) runs at {b.text('StereoBM')} at {group}, "
                                  f"short of the {number(TARGET_BALANCED_X_STEREOBM)} x target."))
        elif b.values[0] < TARGET_BALANCED_X_STEREOBM:
            report.losses.append(("Targets", f"`balanced` (band SGM) meets {number(TARGET_BALANCED_X_STEREOBM)} x "
                                  f"StereoBM on the median only: {b.text('StereoBM')} at {group}."))
    if q.median is not None:
        met = q.median >= TARGET_QUALITY_X_STEREOSGBM
        lines.append(f"band SGM `quality` at least {number(TARGET_QUALITY_X_STEREOSGBM)} x StereoSGBM's frame rate: "
                     f"**{'met' if met else 'missed'}**, {q.text(SGBM_RATE)}.")
        if not met:
            report.losses.append(("Targets", f"`quality` (band SGM) runs at {q.text(SGBM_RATE)} at "
                                  f"{group}, short of the {number(TARGET_QUALITY_X_STEREOSGBM)} x target."))
    report.add("Against the targets" + (f" (the table's run and {len(repeats)} more of realtime, balanced and "
                                        "quality right after it, same command with --presets realtime,balanced,"
                                        "quality)" if repeats else "") + ":\n\n" +
               "\n".join(f"- {line}" for line in lines))
    for m, r in records.items():
        if r["backend"] is None:
            continue
        faster = [f"{method_plain(peer)} ({ms(records[peer]['median_ms'])} ms)" for peer in (STEREOBM, STEREOSGBM)
                  if peer in records and r["median_ms"] > records[peer]["median_ms"]]
        if faster:
            report.losses.append(("Speed", f"At {group}, `{m}` ({ms(r['median_ms'])} ms) is slower than "
                                  f"{join_words(faster)}."))

    # Quality against frame rate.
    points = [(m, r["fps"], ev2003.methods[m]["average_percent_bad"], r["backend"] is None)
              for m, r in records.items()
              if m in ev2003.methods and ev2003.methods[m]["average_percent_bad"] is not None]
    report.add("### Quality against frame rate")
    missing = [m for m in records if m not in ev2003.methods] + [m for m in ev2003.method_order if m not in records]
    report.add(f"Average percent bad on Middlebury 2003 (the first table) against the frame rate at {group} (the "
               "table above), for every method in both runs" +
               (f"; not in both: {join_words(method_plain(m) for m in sorted(set(missing)))}." if missing else "."))
    if points:
        report.image("quality_vs_fps.png", plot_quality_vs_fps(points, group), "quality against frame rate")
    return size, disparities


def speed_resolution(report, bench, file_name):
    report.add("### Frame rate against resolution")
    report.add("Median ms per frame and, in brackets, x StereoBM (the same size, range and threads), over the "
               "thesis sizes; the cpu backend. OpenCV searches the range rounded up to a multiple of 16.")
    report.add(code(bench.command(file_name)))
    report.add(machine_line(bench.settings, bench.file, with_threads=False))
    methods = bench.methods()
    rows = []
    for d in bench.disparities:
        for t in bench.thread_settings:
            for m in methods:
                cells = []
                used = None
                for size in bench.sizes:
                    r = bench.find(m, size, d, t)
                    if r is None:
                        cells.append("-")
                        continue
                    used = r["threads"]
                    cells.append(f"{ms(r['median_ms'])} ({ratio(r['ratio'])})")
                if used is not None:
                    rows.append([d, used, method_name(m)] + cells)
    report.add(table(["disparities", "threads", "method"] + [size_text(s) for s in bench.sizes], rows,
                     ["---:", "---:", "---"] + ["---:"] * len(bench.sizes)))
    d = pick(bench.disparities, 64)
    t = pick(bench.thread_settings, 2)
    series = []
    for m in methods:
        points = [(size, r["fps"]) for size in bench.sizes for r in [bench.find(m, size, d, t)] if r is not None]
        if points:
            series.append((m, points))
    bm = bench.find(STEREOBM, bench.sizes[0], d, t)
    group = f"{d} disparities, {bm['threads'] if bm else t} threads"
    if series:
        report.image("fps_vs_resolution.png", plot_fps_vs_resolution(series, bench.sizes, group),
                     "frame rate against resolution")
    # Trend of the ratio with the size, and the losses.
    notes = []
    for m in bench.presets:
        first = bench.find(m, bench.sizes[0], d, t)
        last = bench.find(m, bench.sizes[-1], d, t)
        if first and last and first["ratio"] is not None and last["ratio"] is not None:
            notes.append(f"`{m}` {ratio(first['ratio'])} x StereoBM at {size_text(bench.sizes[0])}, "
                         f"{ratio(last['ratio'])} x at {size_text(bench.sizes[-1])}")
    if notes:
        report.add(f"At {group}: " + "; ".join(notes) + ".")
    for m in bench.presets:
        for peer in (STEREOBM, STEREOSGBM):
            slower = []
            total = 0
            for dd in bench.disparities:
                for tt in bench.thread_settings:
                    for size in bench.sizes:
                        r, pr = bench.find(m, size, dd, tt), bench.find(peer, size, dd, tt)
                        if r is None or pr is None:
                            continue
                        total += 1
                        if r["median_ms"] > pr["median_ms"]:
                            slower.append((size, dd, r["threads"], pr["median_ms"] / r["median_ms"]))
            if not slower:
                continue
            if len(slower) == total:
                lo, hi = min(s[3] for s in slower), max(s[3] for s in slower)
                text = (f"`{m}` is slower than {method_plain(peer)} in every group of the resolution table "
                        f"({ratio(lo)} to {ratio(hi)} x its frame rate).")
            else:
                text = (f"`{m}` is slower than {method_plain(peer)} at " + "; ".join(
                    f"{size_text(s)} / {dd} disparities / {tt} threads ({ratio(x)} x)" for s, dd, tt, x in slower)
                    + f" ({len(slower)} of {total} groups).")
            report.losses.append(("Speed", text))
    return d, t


def speed_stages(report, bench, file_name, d, t):
    presets = [m for m in bench.presets if any(bench.find(m, s, d, t) for s in bench.sizes)]
    if not presets:
        return
    bm = bench.find(STEREOBM, bench.sizes[0], d, t)
    threads = bm["threads"] if bm else t
    report.add("### Where the time goes")
    report.add(f"Median per-stage times in ms (the matcher's own timings, the same run as the table above) at {d} "
               f"disparities, {threads} threads; frame is the whole call, match % its share spent matching.")
    rows = []
    shares = {s: [] for s in STAGES}
    for m in presets:
        for size in bench.sizes:
            r = bench.find(m, size, d, t)
            if r is None:
                continue
            st = r["stages"]
            for s in STAGES:
                if st["frame"] > 0:
                    shares[s].append(st[s] / st["frame"])
            rows.append([f"`{m}`", size_text(size)] + [ms(st[s]) for s in STAGES] + [
                ms(st["frame"]), f"{100 * st['match'] / st['frame']:.0f}" if st["frame"] > 0 else "-"])
    report.add(table(["preset", "size"] + STAGES + ["frame", "match %"], rows, ["---", "---"] + ["---:"] * 8))
    report.add(f"Command: the resolution table's ([{file_name}]({{results}}/{file_name}): `stage_median_ms`; the "
               "other ranges and thread counts are in the same file). "
               + machine_line(bench.settings, bench.file, with_threads=False))
    means = {s: sum(v) / len(v) for s, v in shares.items() if v}
    if not means:
        return
    dominant = max(means, key=lambda s: means[s])
    text = (f"The {dominant} stage takes the largest share: {100 * min(shares[dominant]):.0f} to "
            f"{100 * max(shares[dominant]):.0f} % of the frame over the rows above")
    second = sorted((s for s in means if s != dominant), key=lambda s: -means[s])[0]
    text += f", then {second} ({100 * min(shares[second]):.0f} to {100 * max(shares[second]):.0f} %)."
    if dominant == "match":
        text += (" Matching is the SHD cost and the winner-takes-all with sub-pixel, for both views at every level; "
                 "the right view is matched only to serve the left-right check (with `realtime`'s check on the right "
                 "map's grid, at the finest level its even rows only). It is bound less by the "
                 "popcounts than by the candidates: each tile of pixels computes, per candidate disparity, the "
                 "rectangle of pixels whose search ranges contain it, and on real scenes the union of the ranges in "
                 "a tile is wider than the pixels' own ranges; tighter per-row candidate spans are the next step.")
    report.add(text)
    report.add("The local presets (`realtime` and the thesis variants) make their census codes inside the match "
               "stage (census_match: each strip of rows gets its codes right before its tiles are matched), so "
               "their census column is 0 and their match column includes the census of both views; the band SGM "
               "levels run the census as a stage of its own (`balanced`: its coarsest level; its two finer levels "
               "match with box sums inside the match stage).")
    # How the match stage grows with the range, at the headline-like size.
    if len(bench.disparities) > 1:
        size = pick(bench.sizes, (640, 480))
        growth = []
        for m in presets:
            lo = bench.find(m, size, bench.disparities[0], t)
            hi = bench.find(m, size, bench.disparities[-1], t)
            if lo and hi:
                growth.append(f"`{m}` {ms(lo['stages']['match'])} to {ms(hi['stages']['match'])} ms")
        if growth:
            report.add(f"From {bench.disparities[0]} to {bench.disparities[-1]} disparities at {size_text(size)}, the "
                       "match stage goes: " + "; ".join(growth) + ".")
    # The ratio to StereoBM across sizes (the cache argument holds only when it falls).
    falling = []
    for m in presets:
        first, last = bench.find(m, bench.sizes[0], d, t), bench.find(m, bench.sizes[-1], d, t)
        if first and last and first["ratio"] and last["ratio"] and last["ratio"] < first["ratio"]:
            falling.append(m)
    if falling:
        report.add(f"The ratio to StereoBM falls with the frame size for {join_words(f'`{m}`' for m in falling)}: "
                   "the passes over full-size planes (gray, pyramid, refinement, and for band SGM the census, the "
                   "costs and the path sums) stop fitting in the cache as the frame grows. The local presets' census "
                   "and matching already run over strips of rows that stay in the cache; carrying the other stages "
                   "into those strips is the remedy. (The stretched frames here also magnify the pair: above "
                   "1280x720 its disparities exceed the range and its texture blurs, see the next section for the "
                   "cost per pixel at constant content.)")


def speed_backends(report, bench, file_name):
    report.add("### Backends: reference against cpu")
    first_threads = bench.thread_settings[0]
    rows = []
    for size in bench.sizes:
        for d in bench.disparities:
            for m in bench.presets:
                ref = bench.find(m, size, d, first_threads, backend="reference")
                cpu = bench.find(m, size, d, first_threads, backend="cpu")
                if ref is None or cpu is None or ref["backend"] != "reference":
                    continue
                rows.append([size_text(size), d, f"`{m}`", ms(ref["median_ms"]), ref["frames"], ms(cpu["median_ms"]),
                             cpu["threads"], f"{ref['median_ms'] / cpu['median_ms']:.1f}"])
    report.add("The reference backend is the scalar, single-threaded statement of the pipeline that the cpu backend "
               "(Highway SIMD and threads) is tested against; it is timed with fewer frames at the larger sizes.")
    report.add(code(bench.command(file_name)))
    report.add(machine_line(bench.settings, bench.file, with_threads=False))
    if rows:
        report.add(table(["size", "disparities", "preset", "reference ms", "frames", "cpu ms", "cpu threads",
                          "cpu speed-up"], rows, ["---", "---:", "---"] + ["---:"] * 5))
    else:
        report.add(f"[{file_name}]({{results}}/{file_name}) holds no pair of reference and cpu records.")


def scaling_target(report, bench, small):
    """realtime's time per pixel at the largest size over the smallest, against TARGET_SCALING_PER_PIXEL."""
    large = max(bench.sizes, key=lambda s: s[0] * s[1])
    if "realtime" not in bench.presets or large == small:
        return
    pixels = {size: size[0] * size[1] for size in (small, large)}
    worst = None
    for d in bench.disparities:
        for t in bench.thread_settings:
            a, b = bench.find("realtime", small, d, t), bench.find("realtime", large, d, t)
            if a is None or b is None:
                continue
            r = (b["median_ms"] / pixels[large]) / (a["median_ms"] / pixels[small])
            if worst is None or r > worst[0]:
                worst = (r, d, t)
    if worst is None:
        return
    met = worst[0] <= TARGET_SCALING_PER_PIXEL
    report.add(f"Against the target (`realtime` at {size_text(large)} within {number(TARGET_SCALING_PER_PIXEL)} x "
               f"of its time per pixel at {size_text(small)}, every range and thread count above): "
               f"**{'met' if met else 'missed'}**, at most {worst[0]:.2f} x ({worst[1]} disparities, "
               f"{worst[2]} thread{'s' if worst[2] != 1 else ''}).")
    if not met:
        report.losses.append(("Targets", f"`realtime`'s time per pixel at {size_text(large)} is {worst[0]:.2f} x "
                              f"its time at {size_text(small)} ({worst[1]} disparities, {worst[2]} threads), over the "
                              f"{number(TARGET_SCALING_PER_PIXEL)} x target."))


def loaded_speedups(runs, method, size, d, t1, t2, key="median_ms"):
    """The 2-thread over 1-thread speed-up of a method in each run that timed both, by the median frame
    time (bench's fps) or by key="mean_ms" (the frame rate sustained)."""
    values = []
    for run in runs:
        a, b = run.find(method, size, d, t1), run.find(method, size, d, t2)
        if a is not None and b is not None and a[key] is not None and b[key] is not None:
            values.append(a[key] / b[key])
    return values


def speedup_range(values):
    """'median (lowest-highest)' of speed-ups, or '-' without any."""
    if not values:
        return "-"
    values = sorted(values)
    return f"{statistics.median(values):.2f} ({values[0]:.2f}-{values[-1]:.2f})"


def loaded_targets(report, runs, t1, t2):
    """The loaded targets in every run: each preset at least as fast on t2 threads as on t1, realtime's ratio."""
    first = runs[0]
    size = pick(first.sizes, (640, 480))
    d = pick(first.disparities, 64)
    presets = [m for m in first.presets if m in ("realtime", "balanced", "quality")]
    if not presets:
        return
    held = 0
    per_run = []
    for run in runs:
        slower = [m for m in presets if any(v < 1 for v in loaded_speedups([run], m, size, d, t1, t2))]
        per_run.append(slower)
        held += not slower
    n = len(runs)
    lines = [f"every preset at least as fast on {t2} threads as on {t1}: **{'met' if held == n else 'missed'}**, held "
             f"in {held} of {n} run{'s' if n != 1 else ''}" +
             ("" if held == n else " (slower on 2 threads: " + "; ".join(
                 f"run {i + 1} " + ", ".join(f"`{m}`" for m in slow) for i, slow in enumerate(per_run) if slow) +
              ")") + "."]
    if held < n:
        report.losses.append(("Targets", f"Under the load, a preset ran slower on {t2} threads than on {t1} in "
                              f"{n - held} of {n} runs ({size_text(size)}, {d} disparities)."))
    sustained = [run for run in runs
                 if all(loaded_speedups([run], m, size, d, t1, t2, "mean_ms") for m in presets)]
    if sustained:
        held_mean = sum(not any(v < 1 for m in presets for v in loaded_speedups([run], m, size, d, t1, t2, "mean_ms"))
                        for run in sustained)
        lines.append(f"the same by the frame rate sustained (1000 / the mean frame time, which counts the frames that "
                     f"the OS preempted): held in {held_mean} of {len(sustained)} run{'s' if len(sustained) != 1 else ''}"
                     " (not the target's measure: bench's fps is the median's).")
    rt = Repeated(r["ratio"] for r in (run.find("realtime", size, d, t2) for run in runs) if r is not None)
    if rt.median is not None:
        met = all(v >= TARGET_LOADED_REALTIME_X_STEREOBM for v in rt.values)
        lines.append(f"`realtime` at least {number(TARGET_LOADED_REALTIME_X_STEREOBM)} x StereoBM under the load "
                     f"({t2} threads): **{'met' if met else 'missed'}**, {rt.text('StereoBM')}.")
        if not met:
            report.losses.append(("Targets", f"Under the load `realtime` ran at {rt.text('StereoBM')}, below "
                                  f"{number(TARGET_LOADED_REALTIME_X_STEREOBM)} x in at least one run."))
    where = f"in each of the {n} runs" if n > 1 else "in this run"
    report.add(f"Against the targets ({size_text(size)}, {d} disparities, {where}):\n\n" +
               "\n".join(f"- {line}" for line in lines))


def speed_loaded(report, bench, file_name, load_threads, repeats=()):
    report.add("### On a loaded CPU")
    report.add(f"The same methods while {load_threads} threads of another process keep the cores busy (`--load "
               f"{load_threads}`), as on a robot or an AR device whose cores run other work: each method with 1 and "
               "with 2 threads in the same run. The cpu backend's stages hand their rows out in small chunks to the "
               "matcher's own threads, and a stage waits only for the chunks that have started, never for a thread "
               "that the OS has descheduled (src/cpu/worker_pool.hpp). With an OpenMP parallel loop per stage, each of "
               "the ~40 loops of a frame ended in a barrier for both threads, and under this load 2 threads ran "
               "several times slower than 1.")
    if bench.adapt_threads:
        report.add("A worker that the OS preempts in the middle of a chunk still holds up the end of its stage, so "
                   "the matcher also keeps its recent frame times on its threads and on the calling thread alone, "
                   "runs its frames the faster way and tries the other for 3 frames now and then "
                   "(`MatcherOptions::adapt_threads`, src/cpu/load_policy.hpp; the maps are the same either way). "
                   "The last column counts the frames, warm-up included, that the 2-thread matcher ran alone.")
    runs = [bench] + list(repeats)
    if repeats:
        report.add(f"The table is one run; the same command ran {len(runs)} times in a row (the JSON files "
                   f"{', '.join(f'[{os.path.basename(r.file)}]({{results}}/{os.path.basename(r.file)})' for r in runs)}"
                   "), and the speed-up columns give the median of the runs with their range.")
    report.add("Two measures of speed differ here. bench's times are medians of the frame times, and under this load "
               "they pass over the frames that the OS preempted: a lone thread gets about two thirds of a core (the "
               "cores column: CPU time of the bench process per second of the timing, its waiting threads included), "
               "but most of its frames are shorter than a scheduler time slice and run whole, so its median frame "
               "is close to its idle one. A 2-thread frame is held up whenever either thread is preempted in the "
               "middle of a chunk, so more of its frames are, and its median gains less than its share of the "
               "cores. The sustained speed-up divides the mean frame times (frames per second of a stream), "
               "which count every preempted frame.")
    report.add(code(bench.command(file_name)))
    report.add(machine_line(bench.settings, bench.file, with_threads=False))
    if len(bench.thread_settings) < 2:
        report.add(f"[{file_name}]({{results}}/{file_name}) has one thread setting: nothing to compare.")
        return
    t1, t2 = bench.thread_settings[0], bench.thread_settings[1]
    rows = []
    for size in bench.sizes:
        for d in bench.disparities:
            for m in bench.methods():
                a = bench.find(m, size, d, t1)
                b = bench.find(m, size, d, t2)
                if a is None or b is None:
                    continue
                row = [size_text(size), d, f"`{m}`" if a["backend"] else m, ms(a["median_ms"]),
                       ms(b["median_ms"]), f"{a['median_ms'] / b['median_ms']:.2f}", ratio(b["ratio"])]
                if repeats:
                    row.append(speedup_range(loaded_speedups(runs, m, size, d, t1, t2)))
                row.append(speedup_range(loaded_speedups(runs, m, size, d, t1, t2, "mean_ms")))
                row.append(f"{a['cpu_cores']:.2f} / {b['cpu_cores']:.2f}" if a["cpu_cores"] is not None and
                           b["cpu_cores"] is not None else "-")
                if bench.adapt_threads:
                    row.append(f"{b['frames_alone']} of {b['frames'] + b['warmup_frames']}" if b["frames_alone"] is not None
                               else "-")
                rows.append(row)
    headers = ["size", "disparities", "method", f"{t1} thread ms", f"{t2} threads ms", f"{t2} threads speed-up",
               f"x BM ({t2} threads)"]
    if repeats:
        headers.append(f"speed-up, {len(runs)} runs")
    headers.append(f"sustained speed-up, {len(runs)} run{'s' if len(runs) != 1 else ''}")
    headers.append(f"cores ({t1} / {t2} threads)")
    if bench.adapt_threads:
        headers.append(f"frames alone ({t2} threads)")
    report.add(table(headers, rows, ["---", "---:", "---"] + ["---:"] * (len(headers) - 3)))
    loaded_targets(report, runs, t1, t2)


def sequence_settings(doc):
    """The settings of the sequence benchmark as header() reads them."""
    s = doc.obj("settings")
    keys = ["cpu_model", "cores_online", "simd_target", "threads", "compiler", "build_type", "opencv_version",
            "mctstereo_version", "date"]
    return {k: s[k].value for k in keys}


def streams_temporal(report, doc, file_name):
    settings = doc.obj("settings")
    rows = doc.array("rows")
    frames = settings.whole("frames")
    report.add("### Streams: the temporal prior")
    report.add(f"`stream --temporal` (StereoParams::temporal, docs/PIPELINE.md) on sequences made from each scene: "
               f"a still camera (the pair with fresh Gaussian noise of sigma {settings.num('noise_sigma'):g} on every "
               f"frame) and pans (a window {settings.whole('pan_window_narrower_by')} px narrower than the scene moving "
               f"1 or 12 px a frame, with noise), {frames} frames each, matched frame by frame alone and with the "
               "prior. Figures are means over every frame but the first: bad = percent of the non-occluded pixels "
               "more than 1 px off or invalid; candidates = disparities examined per pixel at the finest level; ms = "
               "the median frame time (one run: compare within a row).")
    report.add(code(settings.text("command_line").replace(REPO_ROOT + "/", "")))
    report.add(f"Machine: {settings.text('cpu_model')}, {settings.whole('cores_online')} cores, SIMD target "
               f"{settings.text('simd_target')}, {settings.whole('threads')} threads; {settings.text('compiler')}, "
               f"mctstereo {settings.text('mctstereo_version')}; {settings.text('date')} "
               f"([{file_name}]({{results}}/{file_name})).")
    groups = {}
    for r in rows:
        groups.setdefault((r.text("preset"), r.text("sequence")), []).append(r)
    summary = []
    for (preset_name, sequence), members in groups.items():
        def mean(mode, key):
            return sum(m.obj(mode).num(key) for m in members) / len(members)
        summary.append([f"`{preset_name}`", sequence, len(members), f"{mean('alone', 'bad_percent'):.2f}",
                        f"{mean('temporal', 'bad_percent'):.2f}", f"{mean('alone', 'candidates'):.2f}",
                        f"{mean('temporal', 'candidates'):.2f}", f"{mean('alone', 'median_ms'):.2f}",
                        f"{mean('temporal', 'median_ms'):.2f}"])
    report.add("Mean over the scenes:")
    report.add(table(["preset", "sequence", "scenes", "bad % alone", "bad % temporal", "candidates alone",
                      "candidates temporal", "ms alone", "ms temporal"], summary, ["---", "---"] + ["---:"] * 7))
    detail = []
    for r in rows:
        a, t = r.obj("alone"), r.obj("temporal")
        detail.append([r.text("scene"), f"`{r.text('preset')}`", r.text("sequence"), f"{a.num('bad_percent'):.2f}",
                       f"{t.num('bad_percent'):.2f}", f"{a.num('candidates'):.2f}", f"{t.num('candidates'):.2f}",
                       f"{a.num('median_ms'):.2f}", f"{t.num('median_ms'):.2f}"])
        worse = t.num("bad_percent") - a.num("bad_percent")
        if worse > 0.1:
            report.losses.append(("Streams", f"`{r.text('preset')}` with the temporal prior on {r.text('scene')}, "
                                             f"{r.text('sequence')}: {t.num('bad_percent'):.2f} % bad against "
                                             f"{a.num('bad_percent'):.2f} % alone"))
    report.add("Per scene:")
    report.add(table(["scene", "preset", "sequence", "bad % alone", "bad % temporal", "candidates alone",
                      "candidates temporal", "ms alone", "ms temporal"], detail, ["---"] * 3 + ["---:"] * 6))


# The box kernel's vector ALU work per pixel-disparity pair, as `bench` models it (apps/bench.cpp,
# box_alu_bound): 15.5 vector operations per vector of int16 lanes of one candidate.
def box_alu_bound(target):
    if target.startswith("AVX3"):
        return 15.5 / (32 * 2)
    if target == "AVX2":
        return 15.5 / (16 * 3)
    if target in ("SSE4", "SSSE3", "NEON"):
        return 15.5 / (8 * 2)
    return 0.0


def speed_scaling(report, bench, file_name):
    report.add("### Cost per pixel, from 640x480 to 4K, and the roofline")
    report.add("The pair repeated at its own size to fill each frame (`--fit tile`), so that every size has the "
               "disparities and the texture of the pair: the time per pixel then shows what the frame size itself "
               "costs. (Stretched, as the other tables are, a 4K frame is the 384x288 pair magnified 10 x: its "
               "disparities exceed a 64-disparity range and its texture is a blur, and the matcher searches wider "
               "bands there.)")
    report.add(code(bench.command(file_name)))
    report.add(machine_line(bench.settings, bench.file, with_threads=False))
    small = min(bench.sizes, key=lambda s: s[0] * s[1])
    rows = []
    for m in bench.presets:
        for d in bench.disparities:
            for t in bench.thread_settings:
                base = bench.find(m, small, d, t)
                if base is None:
                    continue
                base_ns = base["median_ms"] * 1e6 / (small[0] * small[1])
                for size in bench.sizes:
                    r = bench.find(m, size, d, t)
                    if r is None:
                        continue
                    ns = r["median_ms"] * 1e6 / (size[0] * size[1])
                    rows.append([f"`{m}`", size_text(size), d, r["threads"], ms(r["median_ms"]), f"{ns:.2f}",
                                 f"{ns / base_ns:.2f}", ratio(r["ratio"])])
    report.add(table(["preset", "size", "disparities", "threads", "frame ms", "ns per pixel",
                      f"per pixel / {size_text(small)}", "x BM"], rows, ["---", "---", "---:", "---:"] + ["---:"] * 4))
    scaling_target(report, bench, small)
    mhz = bench.cpu_mhz
    bound = box_alu_bound(bench.simd_target)
    rows = []
    for r in bench.records:
        if not r.get("work") or r["backend"] != "cpu":
            continue
        pairs = sum(w["width"] * w["height"] * w["views"] * w["candidates"] for w in r["work"])
        pixels = r["width"] * r["height"]
        thread_ns = r["stages"]["match"] * 1e6 * r["threads"]
        ns_pair = thread_ns / pairs if pairs else 0.0
        cycles = ns_pair * mhz * 1e-3
        rows.append([f"`{r['method']}`", size_text((r["width"], r["height"])), r["num_disparities"], r["threads"],
                     f"{r['work'][0]['candidates']:.2f}", f"{pairs / pixels:.1f}", f"{thread_ns / pixels:.2f}",
                     f"{cycles:.2f}", f"{bound:.2f}" if bound else "-", f"{cycles / bound:.1f}" if bound else "-"])
    report.add(f"The match stage against the machine's limit. Candidates: disparities examined per pixel and view at "
               f"the finest level (`Matcher::level_work()`); pairs/px: pixel-disparity pairs of all levels and both "
               f"views per input pixel; thread ns/px: the stage's median time times its threads, per input pixel; "
               f"cycles/pair at the clock /proc/cpuinfo gives ({mhz:.0f} MHz); bound: the vector ALU work of the box "
               f"kernel per pair on {bench.simd_target or 'this target'} (XOR, popcount and narrowing of the census "
               "word, the running vertical sum, the 5-tap horizontal sum, the winner and runner-up updates: 15.5 "
               "operations per vector of int16 lanes, on two 512-bit ALU ports).")
    report.add(table(["preset", "size", "disparities", "threads", "candidates", "pairs/px", "thread ns/px",
                      "cycles/pair", "bound", "cycles / bound"], rows,
                     ["---", "---", "---:", "---:"] + ["---:"] * 6))
    report.add("Where each stage stands. **Match** runs several times above the ALU bound of its arithmetic: at the "
               "finest level a pixel has 3 to 5 candidates (radius 1 around the coarse prior), fewer than the lanes of "
               "a vector, so the per-pixel work around the candidates (the search range from the 3x3 prior, the "
               "rectangle of a tile that holds a candidate, the sub-pixel fit and the uniqueness test, the right view "
               "matched only for the LR check, at `realtime`'s finest level on its even rows) costs more than the popcounts; the arithmetic bound would need the "
               "whole band of a tile to be as narrow as its pixels' ranges. For `realtime` the stage's time here "
               "includes the census of both views, which runs inside it strip by strip (census_match). **Census** is "
               "an ALU stage: 24 byte compares, as many masked adds and the interleaving stores per vector of "
               "pixels, whose loads address the window's five row pointers at constant offsets; the blocks at a "
               "row's ends read a copy of their window made before the row's interior blocks run, and cost about as "
               "much as interior ones. Made strip by strip into a ring of rows in the matching thread's scratch, "
               "the codes are read from the L1/L2 cache instead of from 33 MB planes per view at 4K, which made "
               "the census and the matching cost more per pixel there than at 640x480. "
               "**Refine** of `realtime` (the median of both views, the LR check, the fill and the median after "
               "it) runs strip by strip as well (refine_left_map, docs/PIPELINE.md), one parallel region in place of "
               "five, and is bound by its arithmetic, which AVX-512 permutes cut (the LR check's partners and the "
               "fill's scans, docs/PIPELINE.md); **gray**/**pyramid** are passes over whole planes, bound by memory "
               "traffic once a plane leaves the L2 cache: their time per pixel is what grows at 4K. Band SGM (`quality` at its two coarser levels, "
               "`balanced` at its coarsest) passes over its volume of costs and sums four times per level, a volume "
               "larger than the L2 cache at every size timed here. Three measurements of SGM at every level (the "
               "previous `quality`) on a 2-core "
               "Zen 5 VM (alternating runs, in both orders) show what its time does and does not follow. Costs of "
               "16 bits in place of bytes (a byte more per entry, three vector operations fewer per path step) "
               "made it 13 % slower on 1 thread and 6 % on 2, at 640x480. Yet picking each row's winners from a "
               "per-thread block while its final sums were still in the cache, instead of writing the sums and "
               "reading them back (some 4 bytes less per entry), saved nothing on 2 threads at 640x480 (1.5 to 3 % "
               "slower, not kept). "
               "And the size of the volume beyond the L3 cache matters little: with the pair tiled, the match "
               "stage on 1 thread took a median 58, 67 and 70 thread-ns per pixel at 320x240, 640x480 and "
               "1280x720 (ranges 52-74, 62-82 and 67-105 over five runs of `bench --data data --fit tile --sizes "
               "320x240,640x480,1280x720 --num-disparities 64 --threads 1 --presets quality --min-time 1`), while "
               "the finest level's costs and sums grow from 7 MB, inside the 32 MB L3, to 88 MB. "
               "`balanced`'s two finer levels and `quality`'s finest match with box sums, as the local presets do.")


def speed_opencl(report, bench, file_name):
    report.add("### The opencl backend")
    device = bench.opencl_device or "(device not recorded)"
    report.add(f"The opencl backend on {device}, against the cpu backend in the same run (2 threads unless the "
               "command says otherwise). Its maps equal the cpu backend's bit for bit (tests/opencl/); on a CPU "
               "through PoCL it shows the cost of the OpenCL path, not GPU speed. Frame times include the upload "
               "of both images and the download of the map.")
    report.add(code(bench.command(file_name)))
    report.add(machine_line(bench.settings, bench.file, with_threads=False))
    threads = bench.thread_settings[0]
    rows = []
    for size in bench.sizes:
        for d in bench.disparities:
            for m in bench.presets:
                cpu = bench.find(m, size, d, threads, backend="cpu")
                ocl = bench.find(m, size, d, threads, backend="opencl")
                if cpu is None or ocl is None or ocl["backend"] != "opencl":
                    continue
                rows.append([size_text(size), d, f"`{m}`", ms(cpu["median_ms"]), ms(ocl["median_ms"]),
                             f"{cpu['median_ms'] / ocl['median_ms']:.2f}"])
    slower = [r for r in rows if float(r[5]) < 1.0]
    if slower:
        report.losses.append(("Speed", f"The opencl backend on {device} is slower than the cpu backend in "
                                       f"{len(slower)} of {len(rows)} cases (down to "
                                       f"{min(float(r[5]) for r in slower):.2f} x cpu)."))
    if not rows:
        report.add(f"[{file_name}]({{results}}/{file_name}) holds no pair of cpu and opencl records.")
        return
    report.add(table(["size", "disparities", "preset", "cpu ms", "opencl ms", "opencl speed (x cpu)"], rows,
                     ["---", "---:", "---"] + ["---:"] * 3))
    # Per-kernel device times (profiling events) of every preset at the first size.
    size, d = bench.sizes[min(1, len(bench.sizes) - 1)], bench.disparities[0]
    kernel_rows, labels = [], []
    for m in bench.presets:
        ocl = bench.find(m, size, d, threads, backend="opencl")
        if ocl is None or ocl["backend"] != "opencl":
            continue
        for k in ocl["stages"]:
            if k not in labels:
                labels.append(k)
        kernel_rows.append((m, ocl["stages"]))
    if kernel_rows:
        report.add(f"Median per frame at {size_text(size)}, {d} disparities, ms: device time of each kernel from "
                   "OpenCL profiling events, host wall time of upload, download (and speckle removal, which this "
                   "backend runs on the host) and of the frame.")
        # A stage only some presets have (the confidence of band SGM) is '-' for the others.
        report.add(table(["preset"] + labels, [[f"`{m}`"] + [ms(st[k]) if k in st else "-" for k in labels]
                                               for m, st in kernel_rows],
                         ["---"] + ["---:"] * len(labels)))


def memory_section(report, bench, file_name):
    report.add("## Memory")
    if not bench.memory:
        report.add(f"[{file_name}]({{results}}/{file_name}) holds no memory records.")
        return
    measures = sorted({r["peak_measure"] for r in bench.memory})
    presets = [p for p in bench.presets if any(r["method"] == p for r in bench.memory)]
    baseline = [r["baseline"] for r in bench.memory]
    how = {"reset": "the peak was reset to the resident memory just before the matcher was built",
           "difference": "the kernel cannot reset the peak, so this is the rise of the peak, which understates "
                         "when the process had been higher before"}
    report.add(
        "Per size, range and preset, a fresh process builds the matcher, matches one frame and reports its peak "
        "resident memory over what it held just before (" + "; ".join(how.get(m, m) for m in measures) +
        f"); the process itself, with OpenCV loaded, held {mib(min(baseline))} to {mib(max(baseline))} MiB before "
        "that, not counted here. estimate: the library's `estimate_memory` for the same parameters. The full cost "
        "volume W x H x D x 2 bytes is what a matcher that stores every cost would need. Band SGM levels whose "
        "costs and sums would exceed `MatcherOptions::sgm_volume_limit` (32 MiB, the default) are aggregated in "
        "segments of rows (docs/PIPELINE.md, \"Band SGM in segments of rows\").")
    report.add("Command:")
    report.add(code(bench.command(file_name)))
    report.add(machine_line(bench.settings, bench.file, with_threads=False))
    keys = sorted({(r["width"], r["height"], r["num_disparities"]) for r in bench.memory},
                  key=lambda k: (k[0] * k[1], k[0], k[2]))
    rows = []
    for w, h, d in keys:
        row = [f"{w}x{h}", d]
        for p in presets:
            r = next((x for x in bench.memory if x["method"] == p and (x["width"], x["height"],
                                                                        x["num_disparities"]) == (w, h, d)), None)
            row.append(f"{mib(r['peak'])} / {mib(r['estimate'])}" if r else "-")
        row.append(mib(w * h * d * 2.0))
        rows.append(row)
    report.add(table(["size", "disparities"] + [f"`{p}` peak / estimate MiB" for p in presets] +
                     ["cost volume MiB"], rows, ["---", "---:"] + ["---:"] * (len(presets) + 1)))
    # Growth with the range, and the largest frame against the cost volume.
    ds = sorted({r["num_disparities"] for r in bench.memory})
    if len(ds) > 1:
        growth = []
        for r in bench.memory:
            if r["num_disparities"] != ds[0]:
                continue
            hi = next((x for x in bench.memory if x["method"] == r["method"] and x["width"] == r["width"] and
                       x["height"] == r["height"] and x["num_disparities"] == ds[-1]), None)
            if hi and r["estimate"] > 0:
                growth.append(hi["estimate"] / r["estimate"] - 1)
        if growth:
            report.add(f"From {ds[0]} to {ds[-1]} disparities the estimate grows by {100 * min(growth):.0f} to "
                       f"{100 * max(growth):.0f} % (the cost volume by {100 * (ds[-1] / ds[0] - 1):.0f} %): it "
                       "follows the search width of the finest level, not the range.")
    w, h, d = max(keys, key=lambda k: (k[0] * k[1], k[2]))
    largest = [r for r in bench.memory if (r["width"], r["height"], r["num_disparities"]) == (w, h, d)]
    if largest:
        peak = max(r["peak"] for r in largest)
        report.add(f"At {w}x{h} with {d} disparities the largest peak ({mib(peak)} MiB) is "
                   f"{100 * peak / (w * h * d * 2.0):.0f} % of the cost volume ({mib(w * h * d * 2.0)} MiB).")
    over = [r for r in bench.memory if r["peak"] > r["estimate"] * 1.5 and r["peak"] - r["estimate"] > 4 * 1048576]
    if over:
        report.add("Where the peak exceeds the estimate by more than half (and 4 MiB), the rest is the frames, "
                   "the output maps and the allocator: " + "; ".join(
                       f"`{r['method']}` {r['width']}x{r['height']}/{r['num_disparities']}" for r in over) + ".")


def previews_section(report, evals):
    report.add("## Disparity previews")
    report.add("Per scene: the left image, the ground truth and the maps of `quality`, `realtime`, StereoBM and "
               "StereoSGBM, each coloured with the turbo colormap over the scene's search range, as `mctstereo "
               "match --color` colours them (black: no disparity, or no ground truth), downscaled. Commands and "
               "machines: the evaluation runs of the Middlebury tables above, whose `--save` wrote the maps.")
    for ev, set_name, label in evals:
        name = f"previews_{set_name}.png"
        data, why = compose_previews(ev, report.previews_dir, label)
        if data is not None:
            report.image(name, data, f"disparity previews, {label}")
        elif os.path.isfile(os.path.join(report.images_dir, name)):
            print(f"make_results.py: note: previews of {set_name} not made ({why}): keeping "
                  f"{os.path.join(report.images_dir, name)}", file=sys.stderr)
            report.add(f"![disparity previews, {label}]({report.images_link}/{name})")
        else:
            print(f"make_results.py: note: previews of {set_name} not made ({why})", file=sys.stderr)
            report.add(f"{label}: no previews (scripts/measure_results.sh saves them).")


def losses_section(report):
    report.add("## Where mctstereo loses")
    report.add("Computed from the tables above: every place where a peer does better than a preset, and every "
               "target missed. Speed: x is the preset's frame rate over the peer's (below 1: slower).")
    if not report.losses:
        report.add("Nowhere in these runs.")
        return
    sections = []
    for section, _ in report.losses:
        if section not in sections:
            sections.append(section)
    for section in sections:
        report.add(f"**{section}.**\n\n" + "\n".join(f"- {line}" for s, line in report.losses if s == section))


def build(results_dir, images_dir, output, previews_dir):
    docs = {name: load(results_dir, name) for name in INPUT_STEPS}
    ev2003 = EvalRun(docs[EVAL_2003])
    ev2005 = EvalRun(docs[EVAL_2005])
    radio = EvalRun(docs[EVAL_RADIOMETRIC], radiometric=True)
    headline = BenchRun(docs[BENCH_HEADLINE])
    repeats = [BenchRun(load(results_dir, name)) for name in BENCH_HEADLINE_REPEATS
               if os.path.isfile(os.path.join(results_dir, name))]
    thesis = BenchRun(docs[BENCH_THESIS])
    backends = BenchRun(docs[BENCH_BACKENDS])
    opencl = BenchRun(docs[BENCH_OPENCL])
    loaded = BenchRun(docs[BENCH_LOADED])
    loaded_repeats = [BenchRun(load(results_dir, name)) for name in BENCH_LOADED_REPEATS
                      if os.path.isfile(os.path.join(results_dir, name))]
    loaded_threads = loaded.load_threads
    scaling = BenchRun(docs[BENCH_SCALING])
    sequence = docs[SEQUENCE_TEMPORAL]
    memory = BenchRun(docs[BENCH_MEMORY])

    report = Report(results_dir, images_dir, output, previews_dir)
    runs = [(EVAL_2003, ev2003.settings), (EVAL_2005, ev2005.settings), (EVAL_RADIOMETRIC, radio.settings),
            (BENCH_HEADLINE, headline.settings)]
    runs += [(os.path.basename(r.file), r.settings) for r in repeats]
    runs += [(BENCH_THESIS, thesis.settings), (BENCH_BACKENDS, backends.settings), (BENCH_OPENCL, opencl.settings),
             (BENCH_LOADED, loaded.settings)]
    runs += [(os.path.basename(r.file), r.settings) for r in loaded_repeats]
    runs += [(BENCH_SCALING, scaling.settings),
             (SEQUENCE_TEMPORAL, sequence_settings(sequence)), (BENCH_MEMORY, memory.settings)]
    header(report, runs)
    quality_2003(report, ev2003)
    quality_2005(report, ev2005)
    exposure_study(report, radio)
    speed_headline(report, headline, BENCH_HEADLINE, ev2003, repeats)
    d, t = speed_resolution(report, thesis, BENCH_THESIS)
    speed_stages(report, thesis, BENCH_THESIS, d, t)
    speed_scaling(report, scaling, BENCH_SCALING)
    speed_backends(report, backends, BENCH_BACKENDS)
    speed_opencl(report, opencl, BENCH_OPENCL)
    speed_loaded(report, loaded, BENCH_LOADED, loaded_threads, loaded_repeats)
    streams_temporal(report, sequence, SEQUENCE_TEMPORAL)
    memory_section(report, memory, BENCH_MEMORY)
    previews_section(report, [(ev2003, "middlebury2003", "Middlebury 2003"),
                              (ev2005, "middlebury2005", "Middlebury 2005/2006")])
    losses_section(report)
    skipped = [(f, x) for f, run in [(BENCH_HEADLINE, headline), (BENCH_THESIS, thesis), (BENCH_BACKENDS, backends),
                                     (BENCH_OPENCL, opencl), (BENCH_LOADED, loaded), (BENCH_SCALING, scaling)]
               for x in run.skipped]
    if skipped:
        report.add("Not measured (from the files' `skipped`): " + "; ".join(
            f"{m} at {size}, {d} disparities: {reason} ({f})" for f, (m, size, d, reason) in skipped) + ".")
    return report


def write_outputs(report, inputs):
    """Writes the Markdown and the figures, each through a temporary file renamed over the old one."""
    outputs = [(report.output, report.markdown().encode("utf-8"))]
    outputs += [(os.path.join(report.images_dir, name), data) for name, data in sorted(report.images.items())]
    real_inputs = {os.path.realpath(p) for p in inputs}
    for path, _ in outputs:
        if os.path.realpath(path) in real_inputs:
            raise InputError(f"{path}: is one of the inputs: refusing to overwrite it")
        if os.path.isdir(path):
            raise InputError(f"{path}: is a folder")
    if report.images:
        os.makedirs(report.images_dir, exist_ok=True)
    for path, data in outputs:
        folder = os.path.dirname(os.path.abspath(path))
        if not os.path.isdir(folder):
            raise InputError(f"cannot write {path}: folder {folder} does not exist")
        temporary = path + ".tmp-make-results"
        with open(temporary, "wb") as f:
            f.write(data)
        os.replace(temporary, path)
        print(f"make_results.py: wrote {path}", file=sys.stderr)


def main():
    parser = argparse.ArgumentParser(description="Rebuild docs/RESULTS.md and its figures from the JSON results.")
    parser.add_argument("--results", default=os.path.join(REPO_ROOT, "docs", "results"),
                        help="folder of the JSON files (default: docs/results)")
    parser.add_argument("--previews", default=os.path.join(REPO_ROOT, "build", "results", "previews"),
                        help="folder of the eval --save previews (default: build/results/previews)")
    parser.add_argument("--output", default=os.path.join(REPO_ROOT, "docs", "RESULTS.md"),
                        help="the Markdown file to write (default: docs/RESULTS.md)")
    parser.add_argument("--images", default=os.path.join(REPO_ROOT, "docs", "images"),
                        help="folder of the figures (default: docs/images)")
    args = parser.parse_args()
    try:
        report = build(args.results, args.images, args.output, args.previews)
        write_outputs(report, [os.path.join(args.results, n) for n in INPUT_STEPS])
    except InputError as error:
        print(f"make_results.py: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
