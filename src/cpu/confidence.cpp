// Confidence: a light pass over the map (one multiply and a divide per pixel), threaded over rows;
// the arithmetic is the reference's, shared through confidence_at().
#include "stages.hpp"

namespace mctstereo::detail::cpu {

void confidence(const Plane<std::uint8_t>& margin, const Plane<std::int16_t>& checked, const Plane<std::int16_t>* right,
                int threshold, Plane<std::uint8_t>& dst) {
  const int w = checked.width(), h = checked.height();
#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) dst.at(x, y) = confidence_at(margin, checked, right, threshold, x, y);
}

}  // namespace mctstereo::detail::cpu
