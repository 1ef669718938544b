// Point-mass ballistics with quadratic drag (the model is derived in physics_ballistics.hpp).
#include <locard/sim/physics_ballistics.hpp>

#include <numbers>

namespace locard::sim {
namespace {

// dv/dt = g - c |v| v
Eigen::Vector3d acceleration(const Eigen::Vector3d& v, const BallisticModel& model) {
  return model.gravity - model.drag_per_metre * v.norm() * v;
}

}  // namespace

double drag_per_metre(double air_density, double drag_coefficient, double diameter, double mass) {
  const double area = std::numbers::pi * diameter * diameter / 4.0;
  return air_density * drag_coefficient * area / (2.0 * mass);
}

BallisticState ballistic_step(const BallisticState& s, const BallisticModel& model, double dt) {
  if (model.drag_per_metre == 0.0) {
    // Constant acceleration: the Taylor series stops at dt^2, so this is the closed form.
    return {s.position + s.velocity * dt + 0.5 * model.gravity * dt * dt,
            s.velocity + model.gravity * dt};
  }
  // Classical RK4 on (x, v).
  const Eigen::Vector3d k1x = s.velocity;
  const Eigen::Vector3d k1v = acceleration(s.velocity, model);
  const Eigen::Vector3d v2 = s.velocity + 0.5 * dt * k1v;
  const Eigen::Vector3d k2v = acceleration(v2, model);
  const Eigen::Vector3d v3 = s.velocity + 0.5 * dt * k2v;
  const Eigen::Vector3d k3v = acceleration(v3, model);
  const Eigen::Vector3d v4 = s.velocity + dt * k3v;
  const Eigen::Vector3d k4v = acceleration(v4, model);
  BallisticState out;
  out.position = s.position + dt / 6.0 * (k1x + 2.0 * v2 + 2.0 * v3 + v4);
  out.velocity = s.velocity + dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
  return out;
}

BallisticState ballistic_closed_form(const BallisticState& start, const Eigen::Vector3d& gravity,
                                     double t) {
  return {start.position + start.velocity * t + 0.5 * gravity * t * t,
          start.velocity + gravity * t};
}

}  // namespace locard::sim
