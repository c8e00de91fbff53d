// Which SIMD target Highway's dynamic dispatch runs on this machine.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/target.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
// Each target's copy returns its own identity, so the dispatched call tells which one was chosen.
const char* TargetName() { return hwy::TargetName(HWY_TARGET); }
}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(TargetName);
const char* simd_target_name() { return HWY_DYNAMIC_DISPATCH(TargetName)(); }
}  // namespace mctstereo::detail::cpu
#endif
