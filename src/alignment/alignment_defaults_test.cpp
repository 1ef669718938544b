// default_alignment_options for every combination of capture, sensor and colour registration,
// and the case model's noise choice by sensor kind (alignment_defaults.hpp, docs/sensors.md).
#include <locard/alignment/alignment_defaults.hpp>

#include <locard/forensics/case_model.hpp>
#include <locard/forensics/reconstruct.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace locard {
namespace {

using ::testing::ElementsAre;
using ::testing::IsEmpty;

constexpr DepthSensorKind kSensors[] = {DepthSensorKind::Unknown, DepthSensorKind::StructuredLight,
                                        DepthSensorKind::TimeOfFlight, DepthSensorKind::Synthetic};
constexpr CaptureKind kCaptures[] = {CaptureKind::Unknown, CaptureKind::HandHeldVideo,
                                     CaptureKind::TripodTurn};

double expected_depth(DepthSensorKind s) {
  switch (s) {
    case DepthSensorKind::StructuredLight: return 3.0;
    case DepthSensorKind::TimeOfFlight: return 4.5;
    case DepthSensorKind::Synthetic: return 8.0;
    case DepthSensorKind::Unknown: break;
  }
  return 4.0;
}

TEST(AlignmentDefaults, EveryTraitCombination) {
  for (DepthSensorKind sensor : kSensors)
    for (CaptureKind capture : kCaptures)
      for (bool registered : {false, true}) {
        SequenceTraits t;
        t.sensor = sensor;
        t.capture = capture;
        t.color_registered_to_depth = registered;
        t.ring_sizes = {5, 3};
        SCOPED_TRACE(describe(t));
        const AlignmentOptions o = default_alignment_options(t);
        EXPECT_EQ(o.mode, capture == CaptureKind::HandHeldVideo ? AlignmentMode::Odometry
                                                                : AlignmentMode::Cumulative);
        EXPECT_DOUBLE_EQ(o.max_depth_m, expected_depth(sensor));
        EXPECT_DOUBLE_EQ(default_max_depth_m(sensor), expected_depth(sensor));
        EXPECT_EQ(o.odometry_method, registered ? IcpMethod::Colored : IcpMethod::PointToPlane);
        if (capture == CaptureKind::TripodTurn)
          EXPECT_THAT(o.ring_sizes, ElementsAre(5u, 3u));
        else
          EXPECT_THAT(o.ring_sizes, IsEmpty());
        // Everything else stays AlignmentOptions' own default.
        const AlignmentOptions plain;
        EXPECT_DOUBLE_EQ(o.voxel_size, plain.voxel_size);
        EXPECT_DOUBLE_EQ(o.min_depth_m, plain.min_depth_m);
        EXPECT_EQ(o.stride, plain.stride);
        EXPECT_DOUBLE_EQ(o.min_verified_share, plain.min_verified_share);

        // reconstruct's parameters take the same values, and case.json names them.
        const auto p = forensics::ReconstructParameters::defaults_for(t);
        EXPECT_EQ(p.alignment.mode, o.mode);
        EXPECT_EQ(p.alignment.odometry_method, o.odometry_method);
        EXPECT_DOUBLE_EQ(p.alignment.max_depth_m, o.max_depth_m);
        const auto j = nlohmann::json::parse(p.to_json());
        EXPECT_EQ(parse_alignment_mode(j.at("mode").get<std::string>()), o.mode);
        EXPECT_EQ(parse_icp_method(j.at("odometry_icp").get<std::string>()), o.odometry_method);
      }
}

TEST(AlignmentDefaults, NamedDatasetsGetTheirSchemes) {
  SequenceTraits seven;  // 7-Scenes
  seven.sensor = DepthSensorKind::StructuredLight;
  seven.capture = CaptureKind::HandHeldVideo;
  seven.color_registered_to_depth = false;
  const AlignmentOptions a = default_alignment_options(seven);
  EXPECT_EQ(a.mode, AlignmentMode::Odometry);
  EXPECT_EQ(a.odometry_method, IcpMethod::PointToPlane);
  EXPECT_DOUBLE_EQ(a.max_depth_m, 3.0);

  SequenceTraits sim;  // scan-sim: Kinect v2 on a tripod
  sim.sensor = DepthSensorKind::TimeOfFlight;
  sim.capture = CaptureKind::TripodTurn;
  sim.ring_sizes = {50, 50};
  const AlignmentOptions b = default_alignment_options(sim);
  EXPECT_EQ(b.mode, AlignmentMode::Cumulative);
  EXPECT_DOUBLE_EQ(b.max_depth_m, 4.5);
  EXPECT_THAT(b.ring_sizes, ElementsAre(50u, 50u));
}

TEST(SensorNoise, ModelBySensorKind) {
  using forensics::SensorNoiseModel;
  EXPECT_EQ(SensorNoiseModel::for_sensor(DepthSensorKind::TimeOfFlight).name, "kinect_v2");
  EXPECT_EQ(SensorNoiseModel::for_sensor(DepthSensorKind::StructuredLight).name,
            "structured_light");
  EXPECT_EQ(SensorNoiseModel::for_sensor(DepthSensorKind::Synthetic).name, "structured_light");
  EXPECT_EQ(SensorNoiseModel::for_sensor(DepthSensorKind::Unknown).name, "structured_light");
  // Structured light at 3 m: 1.2 mm + 1.9 mm * 2.6^2 = 14.0 mm (Nguyen et al. 2012).
  EXPECT_NEAR(SensorNoiseModel::for_sensor(DepthSensorKind::StructuredLight).axial_sigma_m(3.0, 0.0),
              0.0012 + 0.0019 * 2.6 * 2.6, 1e-12);
}

}  // namespace
}  // namespace locard
