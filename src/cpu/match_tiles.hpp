// What the cpu backend's matching stages share: the tile layout of match() (src/cpu/match.cpp),
// the rows of census codes a tile reads, and the per-target entry points that census_match()
// (src/cpu/census_match.cpp) calls strip by strip.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "stages.hpp"

namespace mctstereo::detail::cpu {

namespace match_layout {

// Band row length: a multiple of every lane count (int16 vectors are capped at 32 lanes below).
// 16 rows keep the vertical overhead of the running sums ((a - 1) extra Hamming rows per tile and
// candidate) at 25 % for a = 5. Measured on Middlebury cones and a synthetic slanted scene,
// 64 x 32 and 128 x 16 tiles ran as fast, 32 x 16, 32 x 32 and 128 x 8 up to 15 % slower.
constexpr int kTile = 64;
constexpr int kRows = 16;
// Candidates the band holds at once: 256 x 16 rows x 64 columns x 2 bytes = 512 KiB, which stays
// in the L2 cache between the cost pass that writes it and the WTA pass that reads it. Wider
// unions (more than 256 disparities at one level) go through the band in chunks.
constexpr int kMaxChunk = 256;
constexpr int kMaxLanes16 = 32;
// One row of the vertical sum V (int16): a front margin of a vector (the horizontal sums start at
// a vector boundary left of the first needed column), the tile with its window margins, and the
// overrun of the last vector.
constexpr int kVFront = 32;
constexpr int kVLen = kVFront + kTile + 64 + 32;
constexpr std::size_t kVBytes = kVLen * sizeof(std::int16_t);
constexpr std::size_t kVRowsBytes = kRows * kVBytes;  // one V row per output row
constexpr std::size_t kStateWords = 8;  // WTA state vectors per pixel vector (see WtaTile)
constexpr std::size_t kStateBytes = kStateWords * kRows * kTile * sizeof(std::int16_t);
constexpr std::size_t kBandBytesPerCandidate = kRows * kTile * sizeof(std::int16_t);
constexpr std::size_t kFixedBytes = kVRowsBytes + kStateBytes;
// Rows of codes above and below a tile that its SHD window reads at most (a <= 9).
constexpr int kMaxWindowHalf = 4;

}  // namespace match_layout

/// Rows of census codes, addressed by image row: the planes of a CensusCodes, or a ring of rows in
/// a thread's scratch (census_match's strips), where image row y lives in slot y % ring. Each row
/// is laid out as a Plane row: kCodePad replicated columns on both sides, 64 bytes of slack.
struct CodeRows {
  int words = 0, width = 0, height = 0;  // the image's
  std::array<std::uint32_t*, 3> data{};  // column 0 of slot 0, per word
  std::ptrdiff_t stride = 0;             // elements from one slot to the next
  int ring = 0;                          // 0: slot y is row y (whole planes)
  int row_lo = 0, row_hi = -1;           // the image rows the slots hold now

  std::uint32_t* row(int k, int y) const { return data[k] + (ring > 0 ? y % ring : y) * stride; }

  static CodeRows of(const CensusCodes& codes) {
    CodeRows r;
    r.words = codes.words;
    r.width = codes.plane[0].width();
    r.height = codes.plane[0].height();
    for (int k = 0; k < codes.words; ++k) r.data[k] = const_cast<std::uint32_t*>(codes.plane[k].row(0));
    r.stride = codes.plane[0].stride();
    r.row_hi = r.height - 1;
    return r;
  }
};

/// Everything one tile needs, shared by all tiles of a call.
struct MatchJob {
  CodeRows ref, other;
  const SearchRanges* ranges;
  const MatchConfig* config;
  Plane<std::int16_t>* disparity;
  Plane<std::uint8_t>* margin;  // null: not wanted
  int tile_w;   // pixels per tile row (<= kTile): kTile - (a - 1), so that a tile's Hamming rows
                // with the window margins are exactly kTile columns, whole vectors; even, as
                // PriorRangeSegment needs of a tile's first column
  int tiles_x;
};

inline MatchJob make_match_job(const CodeRows& ref, const CodeRows& other, const SearchRanges& ranges,
                               const MatchConfig& config, Plane<std::int16_t>& disparity, Plane<std::uint8_t>* margin) {
  const int tile_w = match_layout::kTile - 2 * (config.shd_window / 2);
  return MatchJob{ref, other, &ranges, &config, &disparity, margin, tile_w, (ref.width + tile_w - 1) / tile_w};
}

/// Bytes every thread's slice of `scratch` holds from its first 64-byte boundary, whatever the
/// slice's start (the driver rounds slices to 64 bytes; tests may not).
inline std::size_t aligned_slice_bytes(const MatchScratch& scratch) {
  return scratch.bytes_per_thread < kAlignment ? 0 : scratch.bytes_per_thread - (kAlignment - 1);
}

/// The first 64-byte boundary of thread `slot`'s slice of `scratch` (the tiles' aligned loads need it).
inline std::uint8_t* aligned_slice(const MatchScratch& scratch, int slot) {
  const auto start = reinterpret_cast<std::uintptr_t>(scratch.data.get() + slot * scratch.bytes_per_thread);
  return reinterpret_cast<std::uint8_t*>((start + kAlignment - 1) / kAlignment * kAlignment);
}

/// Entries of a row of search ranges across a level of width w, with the slack that
/// PriorRangeSegment writes past its end (kRangeSegmentSlack, 64) and that the tiles' vector
/// loads read; rows of whole 64-byte lines.
inline std::size_t prior_row_entries(int width) { return (static_cast<std::size_t>(width) + 64 + 31) / 32 * 32; }
/// Bytes of the ranges of one tile row's coarse rows (kRows / 2 of them, lo and hi) that
/// match_tile_row() makes from the prior.
inline std::size_t prior_rows_bytes(int width) {
  return 2 * (match_layout::kRows / 2) * prior_row_entries(width) * sizeof(std::int16_t);
}

/// Matches the tiles of tile row `tile_row` (image rows 16 tile_row ..), left to right, in one
/// thread's scratch `mem` (64-byte aligned, `bytes` long: at least kFixedBytes and one candidate's
/// band). The codes of the rows the tiles' windows read must be in job.ref and job.other.
/// `prior_rows` (prior_rows_bytes(), 64-byte aligned): where a prior alone gives the ranges, they
/// are made there once for the whole tile row instead of once per tile.
void match_tile_row(const MatchJob& job, int tile_row, std::uint8_t* mem, std::size_t bytes,
                    std::uint8_t* prior_rows);

/// The codes of image rows [y_begin, y_end) into dst (rows and their pad columns), as
/// census_transform() makes them.
void census_rows(const Plane<std::uint8_t>& image, const CensusConfig& config, int y_begin, int y_end,
                 const CodeRows& dst);

}  // namespace mctstereo::detail::cpu
