#include <locard/alignment/alignment_defaults.hpp>

#include <fmt/format.h>

namespace locard {

double default_max_depth_m(DepthSensorKind sensor) {
  switch (sensor) {
    case DepthSensorKind::StructuredLight: return 3.0;
    case DepthSensorKind::TimeOfFlight: return 4.5;
    case DepthSensorKind::Synthetic: return 8.0;
    case DepthSensorKind::Unknown: break;
  }
  return 4.0;
}

AlignmentOptions default_alignment_options(const SequenceTraits& traits, AlignmentOptions base) {
  AlignmentOptions o = std::move(base);
  switch (traits.capture) {
    case CaptureKind::TripodTurn:
      o.mode = AlignmentMode::Cumulative;
      o.ring_sizes = traits.ring_sizes;
      break;
    case CaptureKind::HandHeldVideo: o.mode = AlignmentMode::Odometry; break;
    case CaptureKind::Unknown: o.mode = AlignmentMode::Cumulative; break;
  }
  o.max_depth_m = default_max_depth_m(traits.sensor);
  o.odometry_method =
      traits.color_registered_to_depth ? IcpMethod::Colored : IcpMethod::PointToPlane;
  o.refinement_color = traits.color_registered_to_depth;
  return o;
}

std::string describe(const SequenceTraits& traits) {
  return fmt::format("{}, {}, colour {}", to_string(traits.capture), to_string(traits.sensor),
                     traits.color_registered_to_depth ? "registered" : "not registered");
}

}  // namespace locard
