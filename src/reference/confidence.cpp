// Confidence from the winner's margin and the left-right agreement (docs/PIPELINE.md).
#include "stages.hpp"

namespace mctstereo::detail::reference {

void confidence(const Plane<std::uint8_t>& margin, int margin_shift, const Plane<std::int16_t>& checked,
                const Plane<std::int16_t>* right, int threshold, Plane<std::uint8_t>& dst) {
  const int w = checked.width(), h = checked.height();
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) dst.at(x, y) = confidence_at(margin, margin_shift, checked, right, threshold, x, y);
}

}  // namespace mctstereo::detail::reference
