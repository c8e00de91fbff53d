#include <bit>

#include "stages.hpp"

namespace mctstereo::detail::reference {

void sgm_costs(const CensusCodes& left, const CensusCodes& right, const Plane<std::int16_t>* coarse,
               const SgmBandConfig& config, int shd_window, SgmScratch& /*scratch*/, SgmVolume& volume) {
  const int w = left.plane[0].width(), h = left.plane[0].height();
  const int hr = shd_window / 2;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const Interval band = sgm_band_at(coarse, config, w, x, y);
      const int count = band.hi - band.lo + 1;
      volume.lo.at(x, y) = static_cast<std::int16_t>(band.lo);
      volume.count.at(x, y) = static_cast<std::int16_t>(count);
      for (int k = 0; k < volume.stride; ++k) {
        if (k >= count) {
          volume.set_cost(x, y, k, kSgmInf);
          continue;
        }
        const int d = band.lo + k;
        int c = 0;
        for (int j = -hr; j <= hr; ++j) {
          const int yy = clamp_index(y + j, h);
          for (int i = -hr; i <= hr; ++i) {
            const int xl = clamp_index(x + i, w);
            const int xr = clamp_index(x + i - d, w);
            for (int word = 0; word < left.words; ++word)
              c += std::popcount(left.plane[word].at(xl, yy) ^ right.plane[word].at(xr, yy));
          }
        }
        volume.set_cost(x, y, k, c);
      }
    }
  }
}

}  // namespace mctstereo::detail::reference
