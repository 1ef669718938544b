#pragma once
// floor(x) as an integer without a libm call (x86-64's baseline has no SSE4.1 round): one
// conversion each way and no branch, for the voxel and block keys of the hot loops. x must lie
// within Int's range; callers check their coordinates' range first.

namespace locard::detail {

template <typename Int, typename Real>
Int floor_to_int(Real x) {
  const auto truncated = static_cast<Int>(x);
  return truncated - static_cast<Int>(static_cast<Real>(truncated) > x);
}

}  // namespace locard::detail
