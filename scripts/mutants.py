#!/usr/bin/env python3
"""Mutation testing: puts small deliberate bugs into a scratch copy of the sources, one at a time,
builds, runs the tests, and prints which bugs no test catches (the survivors).

    python3 scripts/mutants.py [--scratch DIR] [--only NAME[,NAME...]] [--jobs N] [--list]

The scratch copy is a git worktree of the commit checked out (HEAD: commit what you want tested; made once under --scratch, default
build/mutants/tree, and reused: its build folder keeps the objects, so each mutant rebuilds only
what it touches). The tests run as a user without OpenCL and without ../shared/data would run
them: the opencl tests are excluded and the scratch tree has no shared data beside it. Each mutant
first runs the tests expected to catch it (fast when they do), then, if they all pass, the rest of
the suite. Not run in CI: a full run takes an hour or more on two cores. Keep the machine
otherwise idle only if you also time things; the result does not depend on load.

A mutant is (name, file, text, replacement, tests): the text must occur exactly once in the file
(the script says so and stops otherwise, so that a refactoring cannot silently disarm a mutant).
"""
import argparse
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# (name, file, text, replacement, ctest regex of the tests expected to catch it)
MUTANTS = [
    # The driver (src/matcher.cpp).
    ("driver: box matching never asks for sub-pixel", "src/matcher.cpp",
     "L.shd_window, params.subpixel && l == 0,", "L.shd_window, false,", "FrameReference|Synthetic"),
    ("driver: band SGM never asks for sub-pixel", "src/matcher.cpp",
     "detail::SgmSelectConfig select{params.subpixel && l == 0,", "detail::SgmSelectConfig select{false,",
     "FrameReference|Synthetic"),
    ("driver: no LR check", "src/matcher.cpp", "    if (params.lr_check) {\n      // Both checks",
     "    if (false) {\n      // Both checks", "FrameReference|Pipeline"),
    ("driver: no fill", "src/matcher.cpp",
     "for (int v = 0; v < kept; ++v) stages->fill_invalid(L.disparity[v], params.fill);", "", "FrameReference"),
    ("driver: no median before the checks", "src/matcher.cpp", "    if (params.median_size > 0) {",
     "    if (false) {", "FrameReference"),
    ("driver: no colour-weighted median", "src/matcher.cpp", "if (finest && params.weighted_median) {",
     "if (false) {", "FrameReference|WeightedMedian"),
    ("driver: the confidence without the right map", "src/matcher.cpp",
     "stages->confidence(margin, L.disparity[0], need_right ? &L.disparity[1] : nullptr,",
     "stages->confidence(margin, L.disparity[0], nullptr,", "FrameReference|Confidence"),
    ("driver: the right view searches around the left view's prior", "src/matcher.cpp",
     "coarsest ? nullptr : &levels[l + 1].disparity[v];", "coarsest ? nullptr : &levels[l + 1].disparity[0];",
     "FrameReference|Pipeline"),
    ("driver: speckle removal with the full-resolution size at every level", "src/matcher.cpp",
     "if (L.speckle > 1)\n      for (int v = 0; v < kept; ++v) stages->remove_speckles(L.disparity[v], L.speckle,",
     "if (L.speckle > 1)\n      for (int v = 0; v < kept; ++v) stages->remove_speckles(L.disparity[v], params.speckle_size,",
     "FrameReference"),
    ("driver: up-scaling clamps to the minimum", "src/matcher.cpp",
     "16 * params.min_disparity, 16 * params.max_disparity(), upscaled[v]",
     "16 * params.min_disparity, 16 * params.min_disparity, upscaled[v]", "FrameReference|Pipeline"),
    # The stages and their shared arithmetic.
    ("gray: RGB converted with BGR weights (cpu)", "src/cpu/gray.cpp", "LumaRow(src.row(y), w, 77, 29, dst.row(y));",
     "LumaRow(src.row(y), w, 29, 77, dst.row(y));", "Gray|FrameReference|Colour"),
    ("census: <= instead of < (reference)", "src/reference/census.cpp",
     "pixel(x + i, y + j) * scale < centre_scaled", "pixel(x + i, y + j) * scale <= centre_scaled",
     "Census|ReferenceMatch"),
    ("sub-pixel: rounding without the half", "src/stages.hpp",
     "const int q = (2 * (num < 0 ? -num : num) + den) / (2 * den);",
     "const int q = (2 * (num < 0 ? -num : num)) / (2 * den);", "Subpixel|Match"),
    ("search range: the radius ignored", "src/stages.hpp",
     "return {std::min(std::max(dmin, 2 * mn - radius), dmax), std::max(std::min(dmax, 2 * mx + radius), dmin)};",
     "return {std::min(std::max(dmin, 2 * mn), dmax), std::max(std::min(dmax, 2 * mx), dmin)};",
     "SearchRanges|Match|FrameReference"),
    ("adaptive P2: no floor at P1", "src/stages.hpp", "return std::max(c.p1, (c.p2 * c.p2_k) / (c.p2_k + diff));",
     "return (c.p2 * c.p2_k) / (c.p2_k + diff);", "Sgm"),
    ("margin: 254 instead of 255", "src/stages.hpp",
     "return second > 0 ? static_cast<std::uint8_t>(255 * (second - best_sum) / second) : 0;",
     "return second > 0 ? static_cast<std::uint8_t>(254 * (second - best_sum) / second) : 0;",
     "Margin|Confidence|Match"),
    ("margin: no rival gives 0 even where the winner is flanked", "src/stages.hpp",
     "if (second == std::numeric_limits<int>::max()) return flanked ? 255 : 0;\n  return second > 0 ? static_cast<std::uint8_t>(255",
     "if (second == std::numeric_limits<int>::max()) return 0;\n  return second > 0 ? static_cast<std::uint8_t>(255",
     "Margin|ReferenceMatch"),
    ("LR check: the threshold exclusive (reference)", "src/reference/lr_check.cpp",
     "std::abs(v - o) <= threshold_q4", "std::abs(v - o) < threshold_q4", "LrCheck|Refine"),
    ("fill: nearest-lower takes the larger (reference)", "src/reference/fill.cpp",
     "else if (mode == FillMode::NearestLower) v = std::min(left, right);",
     "else if (mode == FillMode::NearestLower) v = std::max(left, right);", "Fill|Refine"),
    ("cpu match: margins from the wrong second best", "src/cpu/match.cpp",
     "hn::Store(MarginOf(st, f, l), d16, margins);", "hn::Store(MarginOf(st, l, f), d16, margins);", "CpuMatch"),
    ("validate: P1 > P2 accepted", "src/params.cpp", "else if (sgm_p1 > sgm_p2)", "else if (sgm_p1 > sgm_p2 + 100000)",
     "Params|Cli.Sgm"),
    ("depth: Z of the maps from d - doffs", "src/depth.cpp",
     "inline float depth_of(double disparity, double focal_baseline, double doffs, double max_depth) {\n"
     "  const double denominator = disparity + doffs;",
     "inline float depth_of(double disparity, double focal_baseline, double doffs, double max_depth) {\n"
     "  const double denominator = disparity - doffs;", "Depth"),
    # The program.
    ("match: --right-output writes the left map", "apps/match.cpp",
     "encode_disparity(matcher.right_disparity_q4(), invalid, params.min_disparity, right_format)",
     "encode_disparity(matcher.disparity_q4(), invalid, params.min_disparity, right_format)", "Cli.Match"),
    ("eval: the exposure study's conclusion inverted", "apps/eval.cpp",
     "const bool mct_better = groups[1].mean_degradation < groups[0].mean_degradation;",
     "const bool mct_better = !(groups[1].mean_degradation < groups[0].mean_degradation);", "Cli.EvalRadiometric"),
    ("PFM written top row first", "src/pfm.cpp", "for (int y = h - 1; y >= 0; --y) {  // PFM stores the bottom row first",
     "for (int y = 0; y < h; ++y) {", "Pfm|Cli"),
]


def run(cmd, cwd, log, timeout=None):
    with open(log, "a") as out:
        out.write(f"\n$ {' '.join(cmd)}\n")
        out.flush()
        return subprocess.run(cmd, cwd=cwd, stdout=out, stderr=subprocess.STDOUT, timeout=timeout).returncode


def prepare(scratch, log, jobs):
    tree = os.path.join(scratch, "tree")
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, check=True, capture_output=True,
                          text=True).stdout.strip()
    if not os.path.isdir(tree):
        os.makedirs(scratch, exist_ok=True)
        subprocess.run(["git", "worktree", "add", "--detach", tree, head], cwd=ROOT, check=True)
    else:
        subprocess.run(["git", "checkout", "--detach", "--force", head], cwd=tree, check=True)
    build = os.path.join(tree, "build", "mutants")
    if run(["cmake", "-S", tree, "-B", build, "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release",
            "-DMCTSTEREO_WITH_OPENCL=OFF", "-DMCTSTEREO_BUILD_BENCH=OFF"], tree, log) != 0:
        sys.exit(f"mutants: configuring the scratch tree failed (see {log})")
    if run(["cmake", "--build", build, "-j", str(jobs)], tree, log) != 0:
        sys.exit(f"mutants: the unmutated scratch tree does not build (see {log})")
    if run(["ctest", "--test-dir", build, "-j", str(jobs), "-E", "[Oo]pencl"], tree, log) != 0:
        sys.exit(f"mutants: the unmutated scratch tree fails its tests (see {log})")
    return tree, build


def apply(tree, file, text, replacement):
    path = os.path.join(tree, file)
    with open(path, encoding="utf-8") as f:
        source = f.read()
    count = source.count(text)
    if count != 1:
        sys.exit(f"mutants: {file}: the text of a mutant occurs {count} times, not once: {text!r}")
    with open(path, "w", encoding="utf-8") as f:
        f.write(source.replace(text, replacement))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scratch", default=os.path.join(ROOT, "build", "mutants"))
    parser.add_argument("--only", default="", help="comma-separated numbers (1-based) of the mutants to run")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--list", action="store_true", help="list the mutants and stop")
    args = parser.parse_args()
    chosen = [(i + 1, m) for i, m in enumerate(MUTANTS)]
    if args.only:
        wanted = {int(n) for n in args.only.split(",")}
        chosen = [(i, m) for i, m in chosen if i in wanted]
    if args.list:
        for i, (name, file, text, _, _) in chosen:
            with open(os.path.join(ROOT, file), encoding="utf-8") as f:
                count = f.read().count(text)
            print(f"{i:2d}. {name} ({file}){'' if count == 1 else f': its text occurs {count} times'}")
        return 0
    log = os.path.join(args.scratch, "mutants.log")
    os.makedirs(args.scratch, exist_ok=True)
    tree, build = prepare(args.scratch, log, args.jobs)
    survivors, killed = [], []
    for i, (name, file, text, replacement, tests) in chosen:
        start = time.time()
        apply(tree, file, text, replacement)
        try:
            if run(["cmake", "--build", build, "-j", str(args.jobs)], tree, log) != 0:
                verdict = "killed (does not build)"
            elif run(["ctest", "--test-dir", build, "-j", str(args.jobs), "-R", tests, "-E", "[Oo]pencl",
                      "--stop-on-failure"], tree, log) != 0:
                verdict = "killed"
            elif run(["ctest", "--test-dir", build, "-j", str(args.jobs), "-E", f"[Oo]pencl|{tests}",
                      "--stop-on-failure"], tree, log) != 0:
                verdict = "killed (outside its expected tests)"
            else:
                verdict = "SURVIVED"
        finally:
            subprocess.run(["git", "checkout", "--", file], cwd=tree, check=True)
        (survivors if verdict == "SURVIVED" else killed).append(name)
        print(f"{i:2d}. {verdict:36s} {name} ({time.time() - start:.0f} s)", flush=True)
    # The last build is of the last mutant: put the tree back so that the next run starts clean.
    run(["cmake", "--build", build, "-j", str(args.jobs)], tree, log)
    print(f"\n{len(killed)} killed, {len(survivors)} survived of {len(chosen)} mutants")
    for name in survivors:
        print(f"  survived: {name}")
    return 1 if survivors else 0


if __name__ == "__main__":
    sys.exit(main())
