#pragma once
// Point-mass exterior ballistics: gravity plus quadratic air drag.
//
// Drag model (a constant drag coefficient, no wind, no spin drift, no Mach dependence):
//
//   F_drag = -1/2 rho C_d A |v| v,   A = pi d^2 / 4
//   dv/dt  = g - c |v| v,            c = rho C_d A / (2 m)   [1/m]
//   dx/dt  = v
//
// Without drag (c = 0) the motion has the closed form x(t) = x0 + v0 t + g t^2 / 2; the step
// below is exact for it (up to rounding), so a long flight does not drift off the parabola.
// With drag it is integrated with the classical 4th-order Runge-Kutta method; in the
// gravity-free case the drag alone has the closed form v(t) = v0 / (1 + c |v0| t),
// s(t) = ln(1 + c |v0| t) / c, which the tests use as the check.

#include <Eigen/Core>

namespace locard::sim {

struct BallisticState {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
};

struct BallisticModel {
  Eigen::Vector3d gravity{0.0, 0.0, -9.81};
  double drag_per_metre = 0.0;  // c = rho C_d A / (2 m), 1/m; 0 for no drag
};

// c = rho C_d (pi d^2 / 4) / (2 m).
double drag_per_metre(double air_density, double drag_coefficient, double diameter, double mass);

// One step of length dt (exact without drag, RK4 with it).
BallisticState ballistic_step(const BallisticState& state, const BallisticModel& model, double dt);

// The drag-free closed form at time t after `start`.
BallisticState ballistic_closed_form(const BallisticState& start, const Eigen::Vector3d& gravity,
                                     double t);

}  // namespace locard::sim
