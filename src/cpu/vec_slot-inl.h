// VecSlot<D>: a place for one vector that may be an array element or a struct member. SVE's
// vectors are sizeless types, which C++ allows in neither, so on scalable targets a slot keeps the
// lanes in memory (loaded and stored on each use); on every other target it is the vector type
// itself, and arrays of slots stay in registers as arrays of vectors do. Code reads a slot where it
// expects a vector (the conversion) and assigns a vector to it.
// Included after <hwy/highway.h> by files that use foreach_target.h (Highway's toggled guard).
#if defined(MCTSTEREO_CPU_VEC_SLOT_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef MCTSTEREO_CPU_VEC_SLOT_INL_H_
#undef MCTSTEREO_CPU_VEC_SLOT_INL_H_
#else
#define MCTSTEREO_CPU_VEC_SLOT_INL_H_
#endif

#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {

#if HWY_HAVE_SCALABLE
template <class D>
class VecSlot {
 public:
  VecSlot() {}
  operator hwy::HWY_NAMESPACE::Vec<D>() const { return hwy::HWY_NAMESPACE::LoadU(D(), lanes_); }  // NOLINT
  VecSlot& operator=(hwy::HWY_NAMESPACE::Vec<D> v) {
    hwy::HWY_NAMESPACE::StoreU(v, D(), lanes_);
    return *this;
  }

 private:
  // Highway 1.0's MaxLanes() can be below Lanes() for a fraction of an SVE vector (a Rebind of a
  // CappedTag); HWY_MAX_BYTES bounds every vector of the target.
  hwy::HWY_NAMESPACE::TFromD<D> lanes_[HWY_MAX_BYTES / sizeof(hwy::HWY_NAMESPACE::TFromD<D>)];
};
#else
template <class D>
using VecSlot = hwy::HWY_NAMESPACE::Vec<D>;
#endif

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // MCTSTEREO_CPU_VEC_SLOT_INL_H_
