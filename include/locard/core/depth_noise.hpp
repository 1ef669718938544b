#pragma once
// Published axial noise of consumer depth cameras: one place for the formulas the simulator
// draws from (sim::KinectModel) and the uncertainty budget reads (forensics::CaseModel).
// z in metres, incidence in radians (0: the ray meets the surface head on), sigma in metres.
// The incidence is clamped to `max_incidence_rad` (the sensor's full-dropout angle: beyond it
// nothing is returned, so the formula is never evaluated at grazing 90 degrees).
//
//   time of flight (Kinect v2; Fankhauser et al., ICAR 2015, indoor fit, millimetres):
//     sigma_z = 1.5 - 0.5 z + 0.3 z^2 + 0.1 z^1.5 theta^2 / (pi/2 - theta)^2
//   structured light (Kinect v1; Khoshelham & Elberink 2012, Nguyen, Izadi & Lovell 2012):
//     sigma_z = 0.0012 + 0.0019 (z - 0.4)^2 + 0.0001 / sqrt(z) theta^2 / (pi/2 - theta)^2

#include <numbers>

namespace locard {

// The Kinect v2's full-dropout angle, the default of both formulas' clamp.
inline constexpr double kDepthNoiseMaxIncidenceRad = 87.0 * (std::numbers::pi / 180.0);

double time_of_flight_axial_sigma_m(double z_m, double incidence_rad,
                                    double max_incidence_rad = kDepthNoiseMaxIncidenceRad);
double structured_light_axial_sigma_m(double z_m, double incidence_rad,
                                      double max_incidence_rad = kDepthNoiseMaxIncidenceRad);

}  // namespace locard
