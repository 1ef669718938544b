#pragma once
// One source of the defaults that depend on what the data is (SequenceTraits, filled by the
// readers from the data itself, never from a file or folder name). `locard align`,
// `locard reconstruct`, `locard mesh` and the case model all start from these; command-line
// flags and config files override them. The table and the evidence: docs/sensors.md.
//
//   capture       TripodTurn     -> Cumulative (each view against all earlier ones, features +
//                                   ICP), ring_sizes from the traits
//                 HandHeldVideo  -> Odometry (frame-to-local-model tracking)
//                 Unknown        -> Cumulative: nothing says consecutive frames are close, and
//                                   feature-based registration does not assume they are
//   sensor        StructuredLight -> max depth 3.0 m (noise grows with z^2: 1.9 cm at 3 m)
//                 TimeOfFlight    -> 4.5 m (the Kinect v2's specified range)
//                 Synthetic       -> 8.0 m (rendered depth: the range is the scene's)
//                 Unknown         -> 4.0 m
//   colour        registered      -> odometry's last ICP level Colored (photometric + geometric)
//                 not registered  -> PointToPlane: a photometric term would pull towards the
//                                    wrong pixels (7-Scenes, 374 frames: ATE 78 mm with it,
//                                    48 mm without)

#include <locard/alignment/sequential_alignment.hpp>
#include <locard/io/rgbd_sequence.hpp>

namespace locard {

// `base` (AlignmentOptions{} unless given: the one place the tuning defaults live) with mode,
// max_depth_m, odometry_method, refinement_color and ring_sizes set from `traits`.
AlignmentOptions default_alignment_options(const SequenceTraits& traits,
                                           AlignmentOptions base = {});

// Farthest depth used for alignment and for fusion (metres), by sensor kind.
double default_max_depth_m(DepthSensorKind sensor);

// One line for logs and reports: "hand_held_video, structured_light, colour registered".
std::string describe(const SequenceTraits& traits);

}  // namespace locard
