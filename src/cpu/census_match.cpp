// Census and matching of a level strip by strip: each thread takes a strip of tile rows, makes the
// codes of both views for the rows the strip's windows read, right before it matches the strip's
// tiles, in a ring of rows in its own scratch. The codes are then read from the L1/L2 cache where
// they were written, instead of going out to whole planes and back: at 3840 x 2160 the planes of
// one level are 33 MB per view, and their traffic cost the separate stages more per pixel than at
// 640 x 480.
//
// A tile row (16 image rows) reads the codes of its rows and of a = shd_window / 2 rows above
// and below. The ring holds 16 + 2 x 4 rows (a <= 9): going down a strip, each tile row makes
// only the rows below the previous one's, and they overwrite rows no later tile row reads. Only
// the 2 a rows at the top of a strip are made twice (by this strip and the one above).
//
// The codes are those census_transform() makes and each tile is match()'s own: the result is the
// same bit for bit, for any split of the strips among threads.
#include <algorithm>
#include <cstdlib>

#include "cpu/match_tiles.hpp"
#include "cpu/parallel.hpp"
#include "stages.hpp"

namespace mctstereo::detail::cpu {
namespace {

using match_layout::kMaxWindowHalf;
using match_layout::kRows;

constexpr int kRing = kRows + 2 * kMaxWindowHalf;

std::size_t ring_bytes(int width, int words) {
  return 2 * static_cast<std::size_t>(words) * kRing * Plane<std::uint32_t>::stride_for(width, kCodePad) *
         sizeof(std::uint32_t);
}

// The ring of view v in a thread's slice (64-byte aligned): kRing slots per word, laid out as
// rows of a Plane with kCodePad columns.
CodeRows ring_of(std::uint8_t* base, int v, int words, int width, int height) {
  CodeRows r;
  r.words = words;
  r.width = width;
  r.height = height;
  r.stride = Plane<std::uint32_t>::stride_for(width, kCodePad);
  r.ring = kRing;
  auto* first = reinterpret_cast<std::uint32_t*>(base);
  for (int k = 0; k < words; ++k) r.data[k] = first + (static_cast<std::ptrdiff_t>(v) * words + k) * kRing * r.stride + kCodePad;
  return r;
}

}  // namespace

std::size_t census_match_scratch_bytes(int width, int max_range, int shd_window, int census_words) {
  return ring_bytes(width, census_words) + prior_rows_bytes(width) + match_scratch_bytes(width, max_range, shd_window);
}

void census_match(const CensusMatchJob& job, MatchScratch& scratch) {
  const int w = job.image[0]->width(), h = job.image[0]->height();
  if (w <= 0 || h <= 0) return;
  const int words = census_words(job.census.window);
  int half = job.config[0].shd_window / 2;
  if (job.views > 1) half = std::max(half, job.config[1].shd_window / 2);
  const std::size_t ring = ring_bytes(w, words), rows = prior_rows_bytes(w);
  // Each thread's slice starts at the next 64-byte boundary; after the rings and the tile row's
  // ranges it must hold the tile's fixed buffers and one candidate's band: less is a driver bug,
  // not an input.
  const std::size_t need = ring + rows + match_layout::kFixedBytes + match_layout::kBandBytesPerCandidate;
  if (aligned_slice_bytes(scratch) < need) std::abort();
  if (t_pool && t_pool->size() > scratch.threads) std::abort();  // a scratch slice per thread
  // Strips of several tile rows, about four per thread (so that the others take over the share
  // of a thread the OS deschedules), at most 8: the rows made twice are 2 a per strip.
  const int tile_rows = (h + kRows - 1) / kRows;
  const int per_strip = std::clamp(tile_rows / (4 * std::max(stage_threads(), 1)), 1, 8);
  const int strips = (tile_rows + per_strip - 1) / per_strip;
  parallel_for(
      strips, 1,
      [&](int s0, int s1) {
        std::uint8_t* base = aligned_slice(scratch, thread_slot());
        std::uint8_t* prior_rows = base + ring;
        std::uint8_t* tile_mem = prior_rows + rows;
        const std::size_t tile_bytes = aligned_slice_bytes(scratch) - ring - rows;
        CodeRows codes[2] = {ring_of(base, 0, words, w, h), ring_of(base, 1, words, w, h)};
        for (int s = s0; s < s1; ++s) {
          const int first = s * per_strip, last = std::min(tile_rows, first + per_strip);
          int next = std::max(0, first * kRows - half);  // the next row whose codes are made
          for (int t = first; t < last; ++t) {
            const int lo = std::max(0, t * kRows - half), hi = std::min(h, (t + 1) * kRows + half);
            for (int v = 0; v < 2; ++v) {
              census_rows(*job.image[v], job.census, next, hi, codes[v]);
              codes[v].row_lo = lo;
              codes[v].row_hi = hi - 1;
            }
            next = hi;
            for (int v = 0; v < job.views; ++v) {
              const MatchJob tiles = make_match_job(codes[v], codes[1 - v], job.ranges[v], job.config[v],
                                                    *job.disparity[v], v == 0 ? job.margin : nullptr);
              match_tile_row(tiles, t, tile_mem, tile_bytes, prior_rows);
            }
          }
        }
      },
      scratch.threads);
}

}  // namespace mctstereo::detail::cpu
