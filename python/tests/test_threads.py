# Matchers in several Python threads: compute() releases the GIL, and the maps equal those of one
# matcher at a time.
import threading
import time

import numpy as np

import mctstereo


def variants(left, right):
    """Four different pairs of the same size from the bundled one."""
    return [
        (left, right),
        (np.ascontiguousarray(left[:, :, ::-1]), np.ascontiguousarray(right[:, :, ::-1])),
        (np.ascontiguousarray(left[::-1]), np.ascontiguousarray(right[::-1])),
        ((left // 2 + 40).astype(np.uint8), (right // 2 + 40).astype(np.uint8)),
    ]


def test_matchers_in_threads_give_the_maps_of_one_at_a_time(tsukuba):
    pairs = variants(*tsukuba)
    params = mctstereo.preset("balanced", num_disparities=16)
    sequential = [mctstereo.Matcher(384, 288, params, threads=1).compute(l, r) for l, r in pairs]
    results = [None] * len(pairs)
    errors = []

    def work(i):
        try:
            matcher = mctstereo.Matcher(384, 288, params, threads=1)
            for _ in range(3):
                results[i] = matcher.compute(*pairs[i])
        except Exception as e:  # noqa: BLE001
            errors.append(e)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(len(pairs))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    for got, expected in zip(results, sequential):
        np.testing.assert_array_equal(got, expected)


def test_one_matcher_shared_by_threads_serialises_its_frames(tsukuba):
    pairs = variants(*tsukuba)
    params = mctstereo.preset("realtime", num_disparities=16)
    shared = mctstereo.Matcher(384, 288, params, threads=1)
    sequential = [shared.compute(l, r) for l, r in pairs]
    mismatches = []

    def work(i):
        for _ in range(5):
            if not np.array_equal(shared.compute(*pairs[i]), sequential[i], equal_nan=True):
                mismatches.append(i)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(len(pairs))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not mismatches


def test_compute_releases_the_gil(tsukuba):
    # A slow frame (reference backend, one thread) runs in a worker; the main thread must be able to
    # run Python code meanwhile, so the worker is still matching when the main thread's loop ends.
    left = np.tile(tsukuba[0], (2, 2, 1))
    right = np.tile(tsukuba[1], (2, 2, 1))
    matcher = mctstereo.Matcher(768, 576, mctstereo.preset("quality", num_disparities=32), backend="reference")
    started = threading.Event()

    def work():
        started.set()
        matcher.compute(left, right)

    t0 = time.perf_counter()
    matcher.compute(left, right)
    frame = time.perf_counter() - t0
    worker = threading.Thread(target=work)
    worker.start()
    started.wait()
    time.sleep(frame * 0.05)
    counter = 0
    deadline = time.perf_counter() + frame * 0.2
    while time.perf_counter() < deadline:
        counter += 1
    still_matching = worker.is_alive()
    worker.join()
    assert counter > 0 and still_matching, f"frame {frame:.2f} s, main thread ran {counter} iterations"


def test_adapting_the_threads_keeps_the_maps(tsukuba):
    # adapt_threads (the default) runs some frames on one thread (frames 4 to 6 at least, the
    # first trial); adapt_threads=False none. The maps are the same frame after frame.
    left, right = tsukuba
    params = mctstereo.preset("quality", num_disparities=32)
    adapting = mctstereo.Matcher(384, 288, params, threads=2)
    fixed = mctstereo.Matcher(384, 288, params, threads=2, adapt_threads=False)
    for _ in range(20):
        np.testing.assert_array_equal(adapting.compute(left, right), fixed.compute(left, right))
    if adapting.threads > 1:  # a machine of one core gives a matcher of one thread
        assert adapting.frames_alone >= 2
    assert fixed.frames_alone == 0


def test_single_threaded_frames_keep_the_maps(tsukuba):
    # single_threaded=True runs the next frames on the calling thread alone (frames_alone counts
    # them, adapt_threads off counts nothing else) with the maps of all the threads.
    left, right = tsukuba
    params = mctstereo.preset("balanced", num_disparities=32)
    a = mctstereo.Matcher(384, 288, params, threads=2, adapt_threads=False)
    b = mctstereo.Matcher(384, 288, params, threads=2, adapt_threads=False)
    assert a.single_threaded is False
    for frame in range(6):
        a.single_threaded = 2 <= frame < 4
        assert a.single_threaded == (2 <= frame < 4)
        np.testing.assert_array_equal(a.compute(left, right), b.compute(left, right))
    assert a.frames_alone == (2 if a.threads > 1 else 0)
    assert b.frames_alone == 0
