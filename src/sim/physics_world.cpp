// Bullet world for a physics scenario (see physics_world.hpp for the model and its limits).
#include <locard/sim/physics_world.hpp>

#include <locard/core/error.hpp>
#include <locard/sim/counter_rng.hpp>
#include <locard/sim/physics_ballistics.hpp>

#include <fmt/format.h>

#include <btBulletCollisionCommon.h>
#include <btBulletDynamicsCommon.h>
#include <BulletCollision/NarrowPhaseCollision/btRaycastCallback.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <sstream>

namespace locard::sim {
namespace {

using Vec = Eigen::Vector3d;
using Quat = Eigen::Quaterniond;

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kPenetrationTolerance = 0.005;  // m: deeper start overlaps are errors
constexpr double kTouchDistance = 0.002;         // m: a manifold point this close is a contact
constexpr double kContactGap = 0.1;              // s: untouched this long ends a contact
constexpr double kRestLinear = 0.02;             // m/s
constexpr double kRestAngular = 0.1;             // rad/s
constexpr double kRestWindow = 0.25;             // s quiet before a rest is reported
// A ragdoll's small limbs keep trembling against the floor under their joint limits (a few
// tenths of a radian per second); looser thresholds let it settle, and Bullet puts it to sleep.
constexpr double kRagdollRestLinear = 0.05;      // m/s
constexpr double kRagdollRestAngular = 0.5;      // rad/s
constexpr double kSurfaceSkip = 0.001;           // m: hits this close to a muzzle are ignored
constexpr double kFloorBin = 0.02;          // m: height bins of the floor search
constexpr double kFloorLevelDeg = 20.0;     // up-facing triangles within this of level
constexpr double kFloorShareOfPeak = 0.25;  // the lowest bin with this share of the peak area
constexpr double kFloorCell = 0.1;          // m: grid of the inferred floor patches
constexpr double kFloorBand = 0.05;         // m: level triangles this near the floor are floor
constexpr std::size_t kMaxFloorCells = 250'000;
constexpr double kLeftModelMargin = 0.5;    // m beyond the mesh's bounds: left the model
constexpr int kInferredFloorIndex = -2;     // user index of the plane (the mesh is -1)
constexpr double kExitSkip = 0.05;  // m: back faces ignored near a muzzle on a surface

btVector3 bt(const Vec& v) { return {v.x(), v.y(), v.z()}; }
Vec eig(const btVector3& v) { return {v.x(), v.y(), v.z()}; }
btQuaternion bt(const Quat& q) { return {q.x(), q.y(), q.z(), q.w()}; }
Quat eig(const btQuaternion& q) { return Quat(q.w(), q.x(), q.y(), q.z()); }
btTransform bt_pose(const Vec& position, const Quat& rotation) {
  return btTransform(bt(rotation), bt(position));
}

Quat rotation_rpy_deg(const Vec& rpy) {
  return Quat(Eigen::AngleAxisd(rpy.z() * kDeg, Vec::UnitZ()) *
              Eigen::AngleAxisd(rpy.y() * kDeg, Vec::UnitY()) *
              Eigen::AngleAxisd(rpy.x() * kDeg, Vec::UnitX()));
}

std::string fmt_vec(const Vec& v) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(3);
  s << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return s.str();
}

std::string quoted_place(const std::string& list, std::size_t index, const std::string& name) {
  return list + "[" + std::to_string(index) + "] \"" + name + "\"";
}

// A scenario entry that owns one or more bodies (owner 0 is the scene mesh).
struct Owner {
  std::string name;
  std::string kind;   // "mesh", "object", "ragdoll", "avatar"
  std::string where;  // place in the scenario file, for errors
  std::vector<std::size_t> bodies;
  std::size_t anchor = 0;  // body whose pose stands for the owner (ragdoll: pelvis)
  double quiet_since = -1.0;
  bool rest_reported = false;
  bool left_model = false;
  std::size_t avatar = std::numeric_limits<std::size_t>::max();
};

struct Body {
  std::unique_ptr<btCollisionShape> shape;
  std::unique_ptr<btDefaultMotionState> motion;
  std::unique_ptr<btRigidBody> rigid;
  std::size_t owner = 0;
  std::string part;
  std::size_t track = 0;
  Vec v_before = Vec::Zero();  // velocities before the current step (contact approach speed)
  Vec w_before = Vec::Zero();
};

struct Projectile {
  const ProjectileSpec* spec = nullptr;
  std::size_t index = 0;
  std::size_t track = 0;
  Vec direction = Vec::UnitX();
  BallisticModel model;
  BallisticState state;
  double time = 0.0;  // of `state`
  double flown = 0.0;
  bool fired = false;
  bool done = false;
};

// Closest ray hit that also reports the mesh triangle, keeps the triangle's own normal (so a
// back face can be told from a front face), can be limited to one object, and can skip hits
// near the ray's start.
class RayHit : public btCollisionWorld::ClosestRayResultCallback {
 public:
  RayHit(const Vec& from, const Vec& to, const btCollisionObject* only = nullptr)
      : ClosestRayResultCallback(bt(from), bt(to)), only_(only), length_((to - from).norm()) {
    m_flags = btTriangleRaycastCallback::kF_KeepUnflippedNormal;
  }
  double skip_any = 0.0;        // m from the start: ignore every hit
  double skip_back_faces = 0.0; // m from the start: ignore back faces
  long triangle = -1;

  bool needsCollision(btBroadphaseProxy* proxy) const override {
    if (only_ && proxy->m_clientObject != only_) return false;
    return ClosestRayResultCallback::needsCollision(proxy);
  }
  btScalar addSingleResult(btCollisionWorld::LocalRayResult& r, bool normal_in_world) override {
    const double along = r.m_hitFraction * length_;
    if (along < skip_any) return m_closestHitFraction;
    if (along < skip_back_faces) {
      const btVector3 n = normal_in_world ? r.m_hitNormalLocal
                                          : r.m_collisionObject->getWorldTransform().getBasis() *
                                                r.m_hitNormalLocal;
      if (n.dot(m_rayToWorld - m_rayFromWorld) > 0.0) return m_closestHitFraction;
    }
    triangle = r.m_localShapeInfo ? r.m_localShapeInfo->m_triangleIndex : -1;
    return ClosestRayResultCallback::addSingleResult(r, normal_in_world);
  }

 private:
  const btCollisionObject* only_;
  double length_;
};

// Every hit of a ray on one object, with the surfaces' own (unflipped) normals.
class RayAllHits : public btCollisionWorld::RayResultCallback {
 public:
  RayAllHits(const Vec& from, const Vec& to, const btCollisionObject* only)
      : m_rayFromWorld(bt(from)), m_rayToWorld(bt(to)), only_(only) {
    m_flags = btTriangleRaycastCallback::kF_KeepUnflippedNormal;
  }
  btVector3 m_rayFromWorld, m_rayToWorld;
  std::vector<std::pair<double, Vec>> hits;  // fraction along the ray, unit normal

  bool needsCollision(btBroadphaseProxy* proxy) const override {
    return proxy->m_clientObject == only_ && RayResultCallback::needsCollision(proxy);
  }
  btScalar addSingleResult(btCollisionWorld::LocalRayResult& r, bool normal_in_world) override {
    m_collisionObject = r.m_collisionObject;
    const btVector3 n = normal_in_world ? r.m_hitNormalLocal
                                        : r.m_collisionObject->getWorldTransform().getBasis() *
                                              r.m_hitNormalLocal;
    hits.emplace_back(r.m_hitFraction, eig(n).normalized());
    return m_closestHitFraction;  // keep looking
  }

 private:
  const btCollisionObject* only_;
};

struct DeepestContact : public btCollisionWorld::ContactResultCallback {
  double depth = 0.0;  // most negative distance
  Vec where = Vec::Zero();
  btScalar addSingleResult(btManifoldPoint& cp, const btCollisionObjectWrapper*, int, int,
                           const btCollisionObjectWrapper*, int, int) override {
    if (cp.getDistance() < depth) {
      depth = cp.getDistance();
      where = eig(cp.getPositionWorldOnB());
    }
    return 0;
  }
};

// Ragdoll layout, as fractions of the body height with the feet at z = 0, facing +x, left +y.
// Each part is a capsule between two sphere centres; masses are segment fractions in the
// spirit of Dempster's tables (hands in the forearms, feet in the shanks).
struct PartLayout {
  const char* name;
  double y, z0, z1, radius, mass;
};
constexpr PartLayout kParts[] = {
    {"pelvis", 0.0, 0.50, 0.58, 0.075, 0.14},
    {"torso", 0.0, 0.65, 0.76, 0.085, 0.36},
    {"head", 0.0, 0.895, 0.935, 0.055, 0.08},
    {"left upper arm", 0.125, 0.66, 0.78, 0.030, 0.028},
    {"left forearm", 0.125, 0.48, 0.62, 0.027, 0.022},
    {"right upper arm", -0.125, 0.66, 0.78, 0.030, 0.028},
    {"right forearm", -0.125, 0.48, 0.62, 0.027, 0.022},
    {"left thigh", 0.05, 0.30, 0.48, 0.040, 0.10},
    {"left shin", 0.05, 0.035, 0.235, 0.033, 0.06},
    {"right thigh", -0.05, 0.30, 0.48, 0.040, 0.10},
    {"right shin", -0.05, 0.035, 0.235, 0.033, 0.06},
};
enum Part { Pelvis, Torso, Head, LUpperArm, LForearm, RUpperArm, RForearm, LThigh, LShin, RThigh, RShin };

class World {
 public:
  World(const Scenario& scenario, const TriangleMesh& scene)
      : s_(scenario),
        dispatcher_(&config_),
        world_(&dispatcher_, &broadphase_, &solver_, &config_) {
    world_.setGravity(bt(s_.gravity));
    world_.getSolverInfo().m_numIterations = 20;
    owners_.push_back({"mesh", "mesh", "the scene mesh", {}, 0});
    add_mesh(scene);
    add_inferred_floor(scene);
    for (std::size_t i = 0; i < s_.objects.size(); ++i) add_object(s_.objects[i], i);
    for (std::size_t i = 0; i < s_.people.size(); ++i) {
      if (s_.people[i].kind == PersonKind::Ragdoll) add_ragdoll(s_.people[i], i);
      else add_avatar(s_.people[i], i);
    }
    for (std::size_t i = 0; i < s_.projectiles.size(); ++i) add_projectile(s_.projectiles[i], i);
    check_start();
  }

  ~World() {
    for (auto it = constraints_.rbegin(); it != constraints_.rend(); ++it)
      world_.removeConstraint(it->get());
    for (auto it = bodies_.rbegin(); it != bodies_.rend(); ++it) world_.removeRigidBody(it->rigid.get());
    if (mesh_body_) world_.removeRigidBody(mesh_body_.get());
    if (floor_body_) world_.removeRigidBody(floor_body_.get());
  }
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  SimulationResult run() {
    const double dt = s_.time_step;
    const auto steps = static_cast<std::size_t>(std::ceil(s_.duration / dt - 1e-9));
    const auto frames = static_cast<std::size_t>(std::floor(s_.duration * s_.fps + 1e-9)) + 1;
    std::size_t next_frame = 0;
    sample(0.0);
    next_frame = 1;
    for (std::size_t n = 0; n < steps; ++n) {
      const double t0 = static_cast<double>(n) * dt;
      const double t1 = static_cast<double>(n + 1) * dt;
      for (auto& owner : owners_)
        if (owner.kind == "avatar") place_avatar(owner, t1);
      for (auto& b : bodies_) {
        b.v_before = eig(b.rigid->getLinearVelocity());
        b.w_before = eig(b.rigid->getAngularVelocity());
      }
      world_.stepSimulation(dt, 0);
      for (auto& p : projectiles_) advance(p, t0, t1);
      detect_contacts(n, t1);
      detect_rest(t1);
      detect_left_model(t1);
      while (next_frame < frames &&
             t1 >= static_cast<double>(next_frame) / s_.fps - 1e-9) {
        sample(t1);
        ++next_frame;
      }
      ++result_.steps;
    }
    const double end = static_cast<double>(steps) * dt;
    for (auto& p : projectiles_) finish(p, end);
    finals(end);
    std::stable_sort(result_.events.begin(), result_.events.end(),
                     [](const SimEvent& a, const SimEvent& b) { return a.time < b.time; });
    return std::move(result_);
  }

 private:
  // --- building -------------------------------------------------------------------------
  void add_mesh(const TriangleMesh& scene) {
    mesh_vertices_.reserve(scene.vertices.size() * 3);
    for (const auto& v : scene.vertices) {
      if (!v.allFinite()) throw InputError("the scene mesh has a non-finite vertex");
      for (int k = 0; k < 3; ++k) mesh_vertices_.push_back(static_cast<btScalar>(v[k]));
    }
    for (std::size_t t = 0; t < scene.triangles.size(); ++t) {
      const auto& tri = scene.triangles[t];
      if (tri[0] >= scene.vertices.size() || tri[1] >= scene.vertices.size() ||
          tri[2] >= scene.vertices.size())
        throw InputError("the scene mesh's triangle " + std::to_string(t) +
                         " names a vertex that does not exist");
      const Eigen::Vector3f e1 = scene.vertices[tri[1]] - scene.vertices[tri[0]];
      const Eigen::Vector3f e2 = scene.vertices[tri[2]] - scene.vertices[tri[0]];
      if (e1.cross(e2).norm() < 1e-12f) continue;  // degenerate: no surface to collide with
      for (int k = 0; k < 3; ++k) mesh_indices_.push_back(static_cast<int>(tri[k]));
      triangle_ids_.push_back(static_cast<long>(t));
    }
    result_.mesh_triangles = triangle_ids_.size();
    if (triangle_ids_.empty()) return;
    btIndexedMesh part;
    part.m_numTriangles = static_cast<int>(triangle_ids_.size());
    part.m_triangleIndexBase = reinterpret_cast<const unsigned char*>(mesh_indices_.data());
    part.m_triangleIndexStride = 3 * sizeof(int);
    part.m_numVertices = static_cast<int>(scene.vertices.size());
    part.m_vertexBase = reinterpret_cast<const unsigned char*>(mesh_vertices_.data());
    part.m_vertexStride = 3 * sizeof(btScalar);
    part.m_indexType = PHY_INTEGER;
    part.m_vertexType = PHY_DOUBLE;
    mesh_array_ = std::make_unique<btTriangleIndexVertexArray>();
    mesh_array_->addIndexedMesh(part, PHY_INTEGER);
    mesh_shape_ = std::make_unique<btBvhTriangleMeshShape>(mesh_array_.get(), true);
    btRigidBody::btRigidBodyConstructionInfo info(0.0, nullptr, mesh_shape_.get());
    info.m_friction = 0.7;
    info.m_restitution = 0.3;
    mesh_body_ = std::make_unique<btRigidBody>(info);
    mesh_body_->setUserIndex(-1);
    world_.addRigidBody(mesh_body_.get());
  }

  // Floor patches over the holes of the floor found in the mesh (see physics_world.hpp).
  void add_inferred_floor(const TriangleMesh& scene) {
    if (s_.gravity.norm() < 1e-9) return;  // no down, no floor
    const Vec up = -s_.gravity.normalized();
    const std::optional<double> floor = infer_floor_height(scene, up);
    if (!floor) return;
    for (const auto& v : scene.vertices) bounds_.extend(v.cast<double>());
    floor_mesh_ = inferred_floor_patches(scene, up, *floor);
    if (floor_mesh_.triangles.empty()) return;  // the scan saw the whole floor
    result_.floor_inferred = true;
    result_.floor_height_m = *floor;
    for (const auto& v : floor_mesh_.vertices)
      for (int k = 0; k < 3; ++k) floor_vertices_.push_back(static_cast<btScalar>(v[k]));
    for (const auto& t : floor_mesh_.triangles)
      for (int k = 0; k < 3; ++k) floor_indices_.push_back(static_cast<int>(t[k]));
    btIndexedMesh part;
    part.m_numTriangles = static_cast<int>(floor_mesh_.triangles.size());
    part.m_triangleIndexBase = reinterpret_cast<const unsigned char*>(floor_indices_.data());
    part.m_triangleIndexStride = 3 * sizeof(int);
    part.m_numVertices = static_cast<int>(floor_mesh_.vertices.size());
    part.m_vertexBase = reinterpret_cast<const unsigned char*>(floor_vertices_.data());
    part.m_vertexStride = 3 * sizeof(btScalar);
    part.m_indexType = PHY_INTEGER;
    part.m_vertexType = PHY_DOUBLE;
    floor_array_ = std::make_unique<btTriangleIndexVertexArray>();
    floor_array_->addIndexedMesh(part, PHY_INTEGER);
    floor_shape_ = std::make_unique<btBvhTriangleMeshShape>(floor_array_.get(), true);
    btRigidBody::btRigidBodyConstructionInfo info(0.0, nullptr, floor_shape_.get());
    info.m_friction = 0.7;
    info.m_restitution = 0.3;
    floor_body_ = std::make_unique<btRigidBody>(info);
    floor_body_->setUserIndex(kInferredFloorIndex);
    floor_owner_ = owners_.size();
    owners_.push_back({"inferred floor", "support", "the floor inferred from the mesh", {}, 0});
    world_.addRigidBody(floor_body_.get());
  }

  void detect_left_model(double t) {
    if (bounds_.isEmpty()) return;
    Eigen::AlignedBox3d inside = bounds_;
    inside.min().array() -= kLeftModelMargin;
    inside.max().array() += kLeftModelMargin;
    for (Owner& o : owners_) {
      if ((o.kind != "object" && o.kind != "ragdoll") || o.left_model) continue;
      const Vec p = eig(bodies_[o.anchor].rigid->getWorldTransform().getOrigin());
      if (inside.contains(p)) continue;
      o.left_model = true;
      SimEvent e;
      e.time = t;
      e.type = "left_model";
      e.body = o.name;
      e.position = p;
      result_.events.push_back(e);
      result_.warnings.push_back(fmt::format(
          "{} left the model at t = {:.3f} s, at {}: it went where the scan saw nothing, and what "
          "it did after that is not supported by the scene",
          o.name, t, fmt_vec(p)));
    }
  }

  std::size_t new_owner(const std::string& name, const std::string& kind, const std::string& where) {
    owners_.push_back({name, kind, where, {}, 0});
    return owners_.size() - 1;
  }

  // Adds a body; mass 0 with `kinematic` makes a keyframed body.
  std::size_t add_body(std::size_t owner, const std::string& part, std::unique_ptr<btCollisionShape> shape,
                       double mass, const Vec& position, const Quat& rotation, double friction,
                       double restitution, bool kinematic, BodyTrack track) {
    Body b;
    b.owner = owner;
    b.part = part;
    b.shape = std::move(shape);
    b.motion = std::make_unique<btDefaultMotionState>(bt_pose(position, rotation));
    btVector3 inertia(0, 0, 0);
    if (mass > 0.0) b.shape->calculateLocalInertia(mass, inertia);
    btRigidBody::btRigidBodyConstructionInfo info(mass, b.motion.get(), b.shape.get(), inertia);
    info.m_friction = friction;
    info.m_restitution = restitution;
    info.m_rollingFriction = 0.0;
    b.rigid = std::make_unique<btRigidBody>(info);
    if (kinematic) {
      b.rigid->setCollisionFlags(b.rigid->getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
      b.rigid->setActivationState(DISABLE_DEACTIVATION);
    } else {
      b.rigid->setSleepingThresholds(kRestLinear, kRestAngular);
    }
    b.rigid->setUserIndex(static_cast<int>(bodies_.size()));
    b.track = result_.tracks.size();
    track.owner = owners_[owner].name;
    result_.tracks.push_back(std::move(track));
    owners_[owner].bodies.push_back(bodies_.size());
    bodies_.push_back(std::move(b));
    world_.addRigidBody(bodies_.back().rigid.get());
    return bodies_.size() - 1;
  }

  void add_object(const ObjectSpec& o, std::size_t index) {
    const std::size_t owner = new_owner(o.name, "object", quoted_place("objects", index, o.name));
    BodyTrack track;
    track.name = o.name;
    track.kind = "object";
    track.color = o.color;
    std::unique_ptr<btCollisionShape> shape;
    double smallest = 0.0;
    switch (o.shape) {
      case ObjectShape::Box: {
        auto box = std::make_unique<btBoxShape>(bt(o.size / 2.0));
        smallest = o.size.minCoeff();
        box->setMargin(std::min(0.01, 0.1 * smallest));  // margin lies inside the box
        shape = std::move(box);
        track.geometry = TrackGeometry::Box;
        track.size = o.size;
        break;
      }
      case ObjectShape::Sphere:
        shape = std::make_unique<btSphereShape>(o.radius);
        smallest = 2.0 * o.radius;
        track.geometry = TrackGeometry::Sphere;
        track.radius = o.radius;
        break;
      case ObjectShape::Mesh: {
        auto hull = std::make_unique<btConvexHullShape>();
        for (const auto& v : o.mesh.vertices) hull->addPoint(btVector3(v.x(), v.y(), v.z()), false);
        hull->recalcLocalAabb();
        hull->optimizeConvexHull();
        hull->setMargin(0.001);  // the hull is inflated by its margin: keep it at 1 mm
        btVector3 lo, hi;
        hull->getAabb(btTransform::getIdentity(), lo, hi);
        smallest = (hi - lo).m_floats[0];
        for (int k = 1; k < 3; ++k) smallest = std::min<double>(smallest, (hi - lo).m_floats[k]);
        shape = std::move(hull);
        track.geometry = TrackGeometry::Mesh;
        track.mesh = o.mesh;
        break;
      }
    }
    const std::size_t id = add_body(owner, "", std::move(shape), o.mass, o.position,
                                    rotation_rpy_deg(o.rotation_deg), o.friction, o.restitution,
                                    false, std::move(track));
    btRigidBody& rb = *bodies_[id].rigid;
    rb.setLinearVelocity(bt(o.velocity));
    rb.setAngularVelocity(bt(o.angular_velocity_deg * kDeg));
    // Continuous collision for thrown objects: sweep a sphere inside the body.
    rb.setCcdMotionThreshold(0.25 * smallest);
    rb.setCcdSweptSphereRadius(0.2 * smallest);
    owners_[owner].anchor = id;
  }

  void add_ragdoll(const PersonSpec& p, std::size_t index) {
    const std::size_t owner = new_owner(p.name, "ragdoll", quoted_place("people", index, p.name));
    const double h = p.height;
    const Quat yaw(Eigen::AngleAxisd(p.yaw_deg * kDeg, Vec::UnitZ()));
    const Vec lift(0.0, 0.0, 0.005);  // lowest point 5 mm above the given floor point
    auto world_point = [&](double y, double z) { return Vec(p.position + lift + yaw * Vec(0.0, y * h, z * h)); };
    CounterRng rng(s_.seed, static_cast<RngStream>(0x5241), index, 0);  // "RA": ragdoll wobble
    std::size_t ids[std::size(kParts)];
    for (std::size_t k = 0; k < std::size(kParts); ++k) {
      const PartLayout& L = kParts[k];
      const double radius = L.radius * h;
      const double length = (L.z1 - L.z0) * h;
      BodyTrack track;
      track.name = p.name + "/" + L.name;
      track.kind = "ragdoll";
      track.geometry = TrackGeometry::Capsule;
      track.radius = radius;
      track.length = length;
      track.color = p.color;
      ids[k] = add_body(owner, L.name, std::make_unique<btCapsuleShapeZ>(radius, length),
                        L.mass * p.mass, world_point(L.y, 0.5 * (L.z0 + L.z1)), yaw, p.friction,
                        0.0, false, std::move(track));
      btRigidBody& rb = *bodies_[ids[k]].rigid;
      rb.setDamping(0.05, 0.85);
      rb.setSleepingThresholds(kRagdollRestLinear, kRagdollRestAngular);
      rb.setDeactivationTime(0.8);
      rb.setLinearVelocity(bt(p.velocity));
      // A seeded wobble of a few degrees per second, so a symmetric stance does not fold
      // exactly straight down.
      const auto [a, b] = rng.normal_pair();
      rb.setAngularVelocity(bt(Vec(a, b, rng.normal()) * (3.0 * kDeg)));
      rb.setCcdMotionThreshold(radius);
      rb.setCcdSweptSphereRadius(0.8 * radius);
    }
    owners_[owner].anchor = ids[Pelvis];
    // Joint frames are built in the world, then expressed in each body's frame.
    auto frame_in = [&](std::size_t id, const btTransform& joint_world) {
      return bodies_[id].rigid->getWorldTransform().inverse() * joint_world;
    };
    // Cone-twist: the twist axis is the frame's x axis, pointing from parent to child.
    auto cone = [&](Part parent, Part child, double y, double z, const Vec& axis_local,
                    double swing1, double swing2, double twist) {
      const Vec x_axis = yaw * axis_local;
      const Quat q = Quat::FromTwoVectors(Vec::UnitX(), x_axis);
      const btTransform joint = bt_pose(world_point(y, z), q);
      auto c = std::make_unique<btConeTwistConstraint>(*bodies_[ids[parent]].rigid,
                                                       *bodies_[ids[child]].rigid,
                                                       frame_in(ids[parent], joint),
                                                       frame_in(ids[child], joint));
      c->setLimit(swing1, swing2, twist);
      world_.addConstraint(c.get(), true);
      constraints_.push_back(std::move(c));
    };
    // Hinge about the body's lateral axis (+y facing +x). Bullet's hinge angle is minus the
    // child's rotation about that axis: a knee bends backwards (child turns positive about +y,
    // angle negative), an elbow forwards (angle positive).
    auto hinge = [&](Part parent, Part child, double y, double z, double low, double high) {
      btMatrix3x3 basis;
      basis.setValue(1, 0, 0, 0, 0, 1, 0, -1, 0);  // columns x, y, axis = (1,0,0), (0,0,-1), (0,1,0)
      const btTransform joint = btTransform(bt(yaw), bt(world_point(y, z))) * btTransform(basis);
      auto c = std::make_unique<btHingeConstraint>(*bodies_[ids[parent]].rigid,
                                                   *bodies_[ids[child]].rigid,
                                                   frame_in(ids[parent], joint),
                                                   frame_in(ids[child], joint), false);
      c->setLimit(low, high);
      world_.addConstraint(c.get(), true);
      constraints_.push_back(std::move(c));
    };
    const double pi = std::numbers::pi;
    cone(Pelvis, Torso, 0.0, 0.615, Vec::UnitZ(), pi / 6, pi / 6, pi / 8);
    cone(Torso, Head, 0.0, 0.85, Vec::UnitZ(), pi / 4, pi / 4, pi / 3);
    cone(Torso, LUpperArm, 0.125, 0.795, -Vec::UnitZ(), pi / 2, pi / 2, pi / 4);
    cone(Torso, RUpperArm, -0.125, 0.795, -Vec::UnitZ(), pi / 2, pi / 2, pi / 4);
    cone(Pelvis, LThigh, 0.05, 0.50, -Vec::UnitZ(), pi / 3, pi / 4, pi / 8);
    cone(Pelvis, RThigh, -0.05, 0.50, -Vec::UnitZ(), pi / 3, pi / 4, pi / 8);
    hinge(LUpperArm, LForearm, 0.125, 0.64, -0.05, 2.5);
    hinge(RUpperArm, RForearm, -0.125, 0.64, -0.05, 2.5);
    hinge(LThigh, LShin, 0.05, 0.27, -2.5, 0.05);
    hinge(RThigh, RShin, -0.05, 0.27, -2.5, 0.05);
  }

  // Feet position and facing of an avatar at time t (linear along its path).
  static std::pair<Vec, double> avatar_pose(const PersonSpec& p, double t) {
    const auto& path = p.path;
    auto heading = [&](std::size_t i, double fallback) {
      const Vec d = path[i + 1].position - path[i].position;
      return std::hypot(d.x(), d.y()) > 1e-9 ? std::atan2(d.y(), d.x()) : fallback;
    };
    double yaw = 0.0;
    for (std::size_t i = 0; i + 1 < path.size(); ++i) {
      yaw = heading(i, yaw);
      if (t <= path[i + 1].time) {
        if (t <= path[i].time) return {path[i].position, yaw};
        const double u = (t - path[i].time) / (path[i + 1].time - path[i].time);
        return {path[i].position + u * (path[i + 1].position - path[i].position), yaw};
      }
    }
    return {path.back().position, yaw};
  }

  void add_avatar(const PersonSpec& p, std::size_t index) {
    const std::size_t owner = new_owner(p.name, "avatar", quoted_place("people", index, p.name));
    owners_[owner].avatar = index;
    BodyTrack track;
    track.name = p.name;
    track.kind = "avatar";
    track.geometry = TrackGeometry::Capsule;
    track.radius = p.radius;
    track.length = p.height - 2.0 * p.radius;
    track.color = p.color;
    const auto [feet, yaw] = avatar_pose(p, 0.0);
    const std::size_t id = add_body(
        owner, "", std::make_unique<btCapsuleShapeZ>(p.radius, p.height - 2.0 * p.radius), 0.0,
        feet + Vec(0, 0, p.height / 2), Quat(Eigen::AngleAxisd(yaw, Vec::UnitZ())), 0.5, 0.0, true,
        std::move(track));
    owners_[owner].anchor = id;
  }

  void place_avatar(const Owner& owner, double t) {
    const PersonSpec& p = s_.people[owner.avatar];
    const auto [feet, yaw] = avatar_pose(p, t);
    bodies_[owner.anchor].motion->setWorldTransform(
        bt_pose(feet + Vec(0, 0, p.height / 2), Quat(Eigen::AngleAxisd(yaw, Vec::UnitZ()))));
  }

  void add_projectile(const ProjectileSpec& spec, std::size_t index) {
    Projectile p;
    p.spec = &spec;
    p.index = index;
    p.direction = spec.direction;
    if (spec.spread_deg > 0.0) {
      // Uniform over the spherical cap of half-angle spread_deg around the aimed direction.
      CounterRng rng(s_.seed, static_cast<RngStream>(0x5350), index, 0);  // "SP": spread
      const double cos_max = std::cos(spec.spread_deg * kDeg);
      const double cos_t = 1.0 - rng.uniform() * (1.0 - cos_max);
      const double sin_t = std::sqrt(std::max(0.0, 1.0 - cos_t * cos_t));
      const double phi = 2.0 * std::numbers::pi * rng.uniform();
      const Vec u = p.direction.unitOrthogonal();
      const Vec w = p.direction.cross(u);
      p.direction = (cos_t * p.direction + sin_t * (std::cos(phi) * u + std::sin(phi) * w)).normalized();
    }
    p.model.gravity = s_.gravity;
    p.model.drag_per_metre =
        drag_per_metre(s_.air_density, spec.drag_coefficient, spec.diameter, spec.mass);
    p.state.position = spec.muzzle;
    p.state.velocity = p.direction * spec.speed;
    p.time = spec.fire_time;
    BodyTrack track;
    track.name = spec.name;
    track.owner = spec.name;
    track.kind = "projectile";
    track.geometry = TrackGeometry::Sphere;
    track.radius = std::max(spec.diameter, 0.02) / 2.0;  // at least 2 cm across, to be seen
    track.color = {230, 40, 40};
    track.visible_from = spec.fire_time;
    if (spec.fire_time > 0.0) {
      track.times.push_back(0.0);
      track.positions.push_back(spec.muzzle);
      track.rotations.push_back(Quat::Identity());
    }
    p.track = result_.tracks.size();
    result_.tracks.push_back(std::move(track));
    projectiles_.push_back(p);
  }

  // --- start checks ----------------------------------------------------------------------
  [[noreturn]] void fail(const std::string& what) const { throw_input_error(s_.source, what); }

  // Counts rays from `from` whose first mesh hit is a back face: a point behind the surface
  // sees back faces in most directions (inside furniture, beyond a wall). Where two surfaces
  // coincide (a bed's side flush with the wall) either may be reported first, so a ray counts
  // as a back-face hit when any surface at its nearest distance faces away.
  bool behind_mesh(const Vec& from, double skip_any, double skip_back) {
    if (!mesh_body_) return false;
    static const Vec kDirections[] = {{1, 0.013, 0.007}, {-1, 0.011, -0.005}, {0.009, 1, 0.012},
                                      {-0.006, -1, 0.01}, {0.012, 0.008, 1}, {-0.01, 0.007, -1}};
    int back = 0, front = 0;
    for (const Vec& d : kDirections) {
      const Vec dir = d.normalized();
      const double length = 1000.0;
      RayAllHits hits(from, from + length * dir, mesh_body_.get());
      world_.rayTest(hits.m_rayFromWorld, hits.m_rayToWorld, hits);
      double nearest = std::numeric_limits<double>::max();
      bool nearest_back = false;
      for (const auto& [fraction, normal] : hits.hits) {
        const double along = fraction * length;
        const bool is_back = normal.dot(dir) > 0.0;
        if (along < skip_any || (is_back && along < skip_back)) continue;
        if (along < nearest - 1e-6) {
          nearest = along;
          nearest_back = is_back;
        } else if (along <= nearest + 1e-6) {
          nearest_back = nearest_back || is_back;
        }
      }
      if (nearest == std::numeric_limits<double>::max()) continue;
      (nearest_back ? back : front) += 1;
    }
    return back > front;
  }

  std::string body_place(const Body& b) const {
    const Owner& o = owners_[b.owner];
    return o.where + (b.part.empty() ? "" : " (" + b.part + ")");
  }

  void check_start() {
    for (const Body& b : bodies_) {
      const Vec centre = eig(b.rigid->getWorldTransform().getOrigin());
      if (mesh_body_) {
        DeepestContact deepest;
        world_.contactPairTest(b.rigid.get(), mesh_body_.get(), deepest);
        if (deepest.depth < -kPenetrationTolerance)
          fail(body_place(b) + ": starts inside the mesh: it cuts into a surface by " +
               std::to_string(static_cast<int>(std::round(-deepest.depth * 1000.0))) + " mm at " +
               fmt_vec(deepest.where) + "; move it clear of the surfaces");
      }
      if (behind_mesh(centre, 0.0, 0.0))
        fail(body_place(b) + ": starts inside the mesh: its centre " + fmt_vec(centre) +
             " lies behind the mesh's surfaces (inside furniture or beyond a wall)");
    }
    for (std::size_t i = 0; i < bodies_.size(); ++i)
      for (std::size_t j = i + 1; j < bodies_.size(); ++j) {
        if (bodies_[i].owner == bodies_[j].owner) continue;
        DeepestContact deepest;
        world_.contactPairTest(bodies_[i].rigid.get(), bodies_[j].rigid.get(), deepest);
        if (deepest.depth < -kPenetrationTolerance)
          fail(body_place(bodies_[i]) + " and " + body_place(bodies_[j]) + ": overlap by " +
               std::to_string(static_cast<int>(std::round(-deepest.depth * 1000.0))) +
               " mm at the start, at " + fmt_vec(deepest.where));
      }
    for (const Projectile& p : projectiles_) {
      const bool on_surface = p.spec->starts_on_surface;
      if (behind_mesh(p.spec->muzzle, kSurfaceSkip, on_surface ? kExitSkip : 0.0))
        fail(quoted_place("projectiles", p.index, p.spec->name) + ": starts inside the mesh: " +
             "its muzzle " + fmt_vec(p.spec->muzzle) + " lies behind the mesh's surfaces");
    }
  }

  // --- stepping --------------------------------------------------------------------------
  void record_projectile(Projectile& p, double t) {
    BodyTrack& track = result_.tracks[p.track];
    if (!track.times.empty() && t <= track.times.back() + 1e-12) {
      track.positions.back() = p.state.position;  // same instant: keep the later position
    } else {
      track.times.push_back(t);
      track.positions.push_back(p.state.position);
      track.rotations.push_back(Quat::Identity());
    }
    track.trail.push_back(p.state.position);
  }

  void advance(Projectile& p, double t0, double t1) {
    if (p.done || t1 < p.spec->fire_time) return;
    if (!p.fired) {
      p.fired = true;
      SimEvent e;
      e.time = p.spec->fire_time;
      e.type = "launch";
      e.body = p.spec->name;
      e.position = p.state.position;
      e.has_velocity = true;
      e.velocity = p.state.velocity;
      e.speed = p.state.velocity.norm();
      e.energy_j = 0.5 * p.spec->mass * e.speed * e.speed;
      result_.events.push_back(e);
      record_projectile(p, p.time);
    }
    const double from_time = std::max(p.time, t0);
    const double h = t1 - from_time;
    if (h <= 0.0) return;
    const BallisticState next = ballistic_step(p.state, p.model, h);
    const Vec chord = next.position - p.state.position;
    RayHit hit(p.state.position, next.position);
    if (p.flown < kExitSkip) {
      hit.skip_any = std::max(0.0, kSurfaceSkip - p.flown);
      if (p.spec->starts_on_surface) hit.skip_back_faces = kExitSkip - p.flown;
    }
    world_.rayTest(hit.m_rayFromWorld, hit.m_rayToWorld, hit);
    if (!hit.hasHit()) {
      p.flown += chord.norm();
      p.state = next;
      p.time = t1;
      record_projectile(p, t1);
      if (p.state.position.norm() > 1e4) {  // far out of any scene
        p.done = true;
        no_impact(p, t1);
      }
      return;
    }
    // The chord is a straight stand-in for the arc (off by at most |g| h^2 / 8).
    const double f = hit.m_closestHitFraction;
    const Vec v = p.state.velocity + f * (next.velocity - p.state.velocity);
    p.flown += f * chord.norm();
    p.state.position = eig(hit.m_hitPointWorld);
    p.state.velocity = v;
    p.time = from_time + f * h;
    p.done = true;
    record_projectile(p, p.time);
    Vec n = eig(hit.m_hitNormalWorld).normalized();
    if (n.dot(v) > 0.0) n = -n;  // facing the incoming bullet
    SimEvent e;
    e.time = p.time;
    e.type = "impact";
    e.body = p.spec->name;
    e.position = p.state.position;
    e.has_normal = true;
    e.normal = n;
    e.has_velocity = true;
    e.velocity = v;
    e.speed = v.norm();
    e.incidence_deg = std::acos(std::clamp(-n.dot(v.normalized()), -1.0, 1.0)) / kDeg;
    e.energy_j = 0.5 * p.spec->mass * e.speed * e.speed;
    e.distance_m = p.flown;
    const btCollisionObject* object = hit.m_collisionObject;
    if (object == mesh_body_.get()) {
      e.other = "mesh";
      if (hit.triangle >= 0 && static_cast<std::size_t>(hit.triangle) < triangle_ids_.size())
        e.triangle = triangle_ids_[static_cast<std::size_t>(hit.triangle)];
    } else if (object->getUserIndex() >= 0) {
      Body& b = bodies_[static_cast<std::size_t>(object->getUserIndex())];
      e.other = owners_[b.owner].name;
      e.other_part = b.part;
      if (!b.rigid->isStaticOrKinematicObject()) {
        b.rigid->activate(true);
        b.rigid->applyImpulse(bt(p.spec->mass * v),
                              bt(p.state.position) - b.rigid->getCenterOfMassPosition());
      }
    }
    result_.events.push_back(e);
  }

  void no_impact(const Projectile& p, double t) {
    SimEvent e;
    e.time = t;
    e.type = "no_impact";
    e.body = p.spec->name;
    e.position = p.state.position;
    e.has_velocity = true;
    e.velocity = p.state.velocity;
    e.speed = p.state.velocity.norm();
    e.distance_m = p.flown;
    result_.events.push_back(e);
  }

  void finish(Projectile& p, double end) {
    if (!p.fired) return;  // fired after the end: nothing happened
    if (!p.done) no_impact(p, end);
    BodyTrack& track = result_.tracks[p.track];
    if (track.times.back() < end - 1e-12) {  // hold the last position to the end
      track.times.push_back(end);
      track.positions.push_back(track.positions.back());
      track.rotations.push_back(Quat::Identity());
    }
  }

  std::size_t owner_of(const btCollisionObject* object) const {
    const int index = object->getUserIndex();
    if (index == kInferredFloorIndex) return floor_owner_;
    return index < 0 ? 0 : bodies_[static_cast<std::size_t>(index)].owner;
  }
  std::string part_of(const btCollisionObject* object) const {
    const int index = object->getUserIndex();
    return index < 0 ? std::string() : bodies_[static_cast<std::size_t>(index)].part;
  }
  Vec velocity_before(const btCollisionObject* object, const Vec& point) const {
    const int index = object->getUserIndex();
    if (index < 0) return Vec::Zero();
    const Body& b = bodies_[static_cast<std::size_t>(index)];
    if (b.rigid->isKinematicObject()) return eig(b.rigid->getLinearVelocity());
    const Vec com = eig(b.rigid->getCenterOfMassPosition());
    return b.v_before + b.w_before.cross(point - com);
  }

  void detect_contacts(std::size_t step, double t) {
    const auto gap_steps = static_cast<std::size_t>(std::ceil(kContactGap / s_.time_step));
    const int manifolds = dispatcher_.getNumManifolds();
    for (int m = 0; m < manifolds; ++m) {
      const btPersistentManifold* manifold = dispatcher_.getManifoldByIndexInternal(m);
      int closest = -1;
      for (int k = 0; k < manifold->getNumContacts(); ++k)
        if (manifold->getContactPoint(k).getDistance() < kTouchDistance &&
            (closest < 0 || manifold->getContactPoint(k).getDistance() <
                                manifold->getContactPoint(closest).getDistance()))
          closest = k;
      if (closest < 0) continue;
      const btCollisionObject* a = manifold->getBody0();
      const btCollisionObject* b = manifold->getBody1();
      std::size_t oa = owner_of(a), ob = owner_of(b);
      if (oa == ob) continue;
      // The moving body first; the mesh always second.
      const btManifoldPoint& cp = manifold->getContactPoint(closest);
      const Vec point = eig(cp.getPositionWorldOnB());
      const Vec normal_b_to_a = eig(cp.m_normalWorldOnB);
      const double approach =
          -(velocity_before(a, point) - velocity_before(b, point)).dot(normal_b_to_a);
      // The scene - the mesh or the inferred floor - always second.
      const auto is_scene = [this](std::size_t owner) {
        return owner == 0 || (floor_owner_ != 0 && owner == floor_owner_);
      };
      if (is_scene(oa) || (!is_scene(ob) && ob < oa)) {
        std::swap(a, b);
        std::swap(oa, ob);
      }
      const auto key = std::make_pair(oa, ob);
      auto it = last_touch_.find(key);
      const bool fresh = it == last_touch_.end() || step > it->second + gap_steps;
      const bool already_this_step = it != last_touch_.end() && it->second == step + 1;
      last_touch_[key] = step + 1;  // stored +1 so 0 means never
      if (!fresh || already_this_step) continue;
      SimEvent e;
      e.time = t;
      e.type = "contact";
      e.body = owners_[oa].name;
      e.part = part_of(a);
      e.other = owners_[ob].name;
      e.other_part = part_of(b);
      e.position = point;
      e.speed = std::max(0.0, approach);
      result_.events.push_back(e);
    }
  }

  void detect_rest(double t) {
    for (Owner& o : owners_) {
      if (o.kind != "object" && o.kind != "ragdoll") continue;
      double v = 0.0, w = 0.0;
      for (std::size_t id : o.bodies) {
        v = std::max<double>(v, bodies_[id].rigid->getLinearVelocity().length());
        w = std::max<double>(w, bodies_[id].rigid->getAngularVelocity().length());
      }
      const bool ragdoll = o.kind == "ragdoll";
      const double rest_v = ragdoll ? kRagdollRestLinear : kRestLinear;
      const double rest_w = ragdoll ? kRagdollRestAngular : kRestAngular;
      if (v < rest_v && w < rest_w) {
        if (o.quiet_since < 0.0) o.quiet_since = t;
        if (!o.rest_reported && t - o.quiet_since >= kRestWindow - 1e-9) {
          o.rest_reported = true;
          const btTransform& pose = bodies_[o.anchor].rigid->getWorldTransform();
          SimEvent e;
          e.time = o.quiet_since;
          e.type = "rest";
          e.body = o.name;
          if (o.kind == "ragdoll") e.part = bodies_[o.anchor].part;
          e.position = eig(pose.getOrigin());
          e.has_rotation = true;
          e.rotation = eig(pose.getRotation());
          result_.events.push_back(e);
        }
      } else if (v > 2.0 * rest_v || w > 2.0 * rest_w) {
        o.quiet_since = -1.0;  // moving again: a later rest is a new event
        o.rest_reported = false;
      }
    }
  }

  void sample(double t) {
    result_.frame_times.push_back(t);
    for (const Body& b : bodies_) {
      BodyTrack& track = result_.tracks[b.track];
      btTransform pose;
      if (b.rigid->isKinematicObject()) b.motion->getWorldTransform(pose);
      else pose = b.rigid->getWorldTransform();
      track.times.push_back(t);
      track.positions.push_back(eig(pose.getOrigin()));
      track.rotations.push_back(eig(pose.getRotation()));
    }
  }

  void finals(double end) {
    for (const Owner& o : owners_) {
      if (o.kind == "mesh" || o.kind == "support") continue;
      const btTransform& pose = bodies_[o.anchor].rigid->getWorldTransform();
      FinalState f;
      f.body = o.name;
      f.kind = o.kind;
      f.position = eig(pose.getOrigin());
      f.rotation = eig(pose.getRotation());
      f.at_rest = o.rest_reported;
      result_.final_states.push_back(f);
    }
    for (const Projectile& p : projectiles_) {
      FinalState f;
      f.body = p.spec->name;
      f.kind = "projectile";
      f.position = p.state.position;
      f.at_rest = p.done && p.fired;
      if (!p.fired) f.position = p.spec->muzzle;
      result_.final_states.push_back(f);
    }
    (void)end;
  }

  const Scenario& s_;
  btDefaultCollisionConfiguration config_;
  btCollisionDispatcher dispatcher_;
  btDbvtBroadphase broadphase_;
  btSequentialImpulseConstraintSolver solver_;
  btDiscreteDynamicsWorld world_;

  std::vector<btScalar> mesh_vertices_;
  std::vector<int> mesh_indices_;
  std::vector<long> triangle_ids_;  // Bullet's triangle index -> the input mesh's
  std::unique_ptr<btTriangleIndexVertexArray> mesh_array_;
  std::unique_ptr<btBvhTriangleMeshShape> mesh_shape_;
  std::unique_ptr<btRigidBody> mesh_body_;
  TriangleMesh floor_mesh_;  // inferred floor patches over the floor's holes
  std::vector<btScalar> floor_vertices_;
  std::vector<int> floor_indices_;
  std::unique_ptr<btTriangleIndexVertexArray> floor_array_;
  std::unique_ptr<btBvhTriangleMeshShape> floor_shape_;
  std::unique_ptr<btRigidBody> floor_body_;
  std::size_t floor_owner_ = 0;
  Eigen::AlignedBox3d bounds_;  // of the mesh's vertices; empty without a floor

  std::vector<Owner> owners_;
  std::vector<Body> bodies_;
  std::vector<std::unique_ptr<btTypedConstraint>> constraints_;
  std::vector<Projectile> projectiles_;
  std::map<std::pair<std::size_t, std::size_t>, std::size_t> last_touch_;
  SimulationResult result_;
};

}  // namespace

std::optional<double> infer_floor_height(const TriangleMesh& scene, const Eigen::Vector3d& up) {
  const double level = std::cos(kFloorLevelDeg * kDeg);
  struct Bin {
    double area = 0.0, area_height = 0.0;
  };
  std::map<long, Bin> bins;  // ordered by height
  for (const auto& tri : scene.triangles) {
    if (tri[0] >= scene.vertices.size() || tri[1] >= scene.vertices.size() ||
        tri[2] >= scene.vertices.size())
      continue;
    const Vec a = scene.vertices[tri[0]].cast<double>(), b = scene.vertices[tri[1]].cast<double>(),
              c = scene.vertices[tri[2]].cast<double>();
    const Vec n = (b - a).cross(c - a);
    const double twice_area = n.norm();
    if (!(twice_area > 1e-12) || n.dot(up) < level * twice_area) continue;  // not up-facing
    const double h = up.dot((a + b + c) / 3.0);
    if (!std::isfinite(h)) continue;
    Bin& bin = bins[std::lround(std::floor(h / kFloorBin))];
    bin.area += 0.5 * twice_area;
    bin.area_height += 0.5 * twice_area * h;
  }
  double peak = 0.0;
  for (const auto& [index, bin] : bins) peak = std::max(peak, bin.area);
  if (peak <= 0.0) return std::nullopt;
  for (const auto& [index, bin] : bins) {
    if (bin.area < kFloorShareOfPeak * peak) continue;
    // The area-weighted height of this bin and its neighbours: a floor at a bin's edge
    // spreads over two bins.
    double area = 0.0, area_height = 0.0;
    for (long k = index - 1; k <= index + 1; ++k)
      if (const auto it = bins.find(k); it != bins.end()) {
        area += it->second.area;
        area_height += it->second.area_height;
      }
    return area_height / area;
  }
  return std::nullopt;
}

TriangleMesh inferred_floor_patches(const TriangleMesh& scene, const Eigen::Vector3d& up_in,
                                    double floor_height) {
  const Vec up = up_in.normalized();
  const Vec e1 = up.unitOrthogonal(), e2 = up.cross(e1);
  Eigen::AlignedBox2d extent;
  for (const auto& v : scene.vertices) extent.extend(Eigen::Vector2d(e1.dot(v.cast<double>()), e2.dot(v.cast<double>())));
  TriangleMesh patches;
  if (extent.isEmpty()) return patches;
  double cell = kFloorCell;
  const auto cells_along = [&](int axis) {  // covering the extent, not beyond it by a cell
    return std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(extent.sizes()[axis] / cell - 1e-6)));
  };
  while (cells_along(0) * cells_along(1) > kMaxFloorCells) cell *= 2.0;
  const std::size_t nu = cells_along(0), nv = cells_along(1);
  std::vector<char> covered(nu * nv, 0);
  const double level = std::cos(kFloorLevelDeg * kDeg);
  const auto centre = [&](std::size_t i, std::size_t j) -> Eigen::Vector2d {
    return extent.min() + Eigen::Vector2d((static_cast<double>(i) + 0.5) * cell,
                                          (static_cast<double>(j) + 0.5) * cell);
  };
  for (const auto& tri : scene.triangles) {
    if (tri[0] >= scene.vertices.size() || tri[1] >= scene.vertices.size() ||
        tri[2] >= scene.vertices.size())
      continue;
    Vec p[3];
    Eigen::Vector2d q[3];
    bool near_floor = true;
    for (int k = 0; k < 3; ++k) {
      p[k] = scene.vertices[tri[k]].cast<double>();
      q[k] = {e1.dot(p[k]), e2.dot(p[k])};
      near_floor = near_floor && std::abs(up.dot(p[k]) - floor_height) <= kFloorBand;
    }
    const Vec n = (p[1] - p[0]).cross(p[2] - p[0]);
    if (!near_floor || !(n.norm() > 1e-12) || n.dot(up) < level * n.norm()) continue;
    // Cells whose centre the triangle covers (seen from above), and the cells of its corners.
    const double area = (q[1] - q[0]).x() * (q[2] - q[0]).y() - (q[1] - q[0]).y() * (q[2] - q[0]).x();
    Eigen::AlignedBox2d box;
    for (const auto& c : q) box.extend(c);
    // Evaluated now: an `auto` Eigen expression would refer to temporaries gone by then.
    const Eigen::Vector2d lo_cell = (box.min() - extent.min()) / cell;
    const Eigen::Vector2d hi_cell = (box.max() - extent.min()) / cell;
    const Eigen::Vector2<long> lo(static_cast<long>(std::floor(lo_cell.x())), static_cast<long>(std::floor(lo_cell.y())));
    const Eigen::Vector2<long> hi(static_cast<long>(std::floor(hi_cell.x())), static_cast<long>(std::floor(hi_cell.y())));
    for (long i = std::max(0L, lo.x()); i <= std::min<long>(static_cast<long>(nu) - 1, hi.x()); ++i)
      for (long j = std::max(0L, lo.y()); j <= std::min<long>(static_cast<long>(nv) - 1, hi.y()); ++j) {
        const Eigen::Vector2d c = centre(static_cast<std::size_t>(i), static_cast<std::size_t>(j));
        bool inside = std::abs(area) > 1e-12;
        for (int k = 0; k < 3 && inside; ++k) {
          const Eigen::Vector2d a = q[k], b = q[(k + 1) % 3];
          const double side = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
          inside = side * area >= 0.0;
        }
        const bool corner_here = (lo.x() == hi.x() && lo.y() == hi.y());
        if (inside || corner_here) covered[static_cast<std::size_t>(i) * nv + static_cast<std::size_t>(j)] = 1;
      }
  }
  // Uncovered cells merged greedily into rectangles, one quad each: fewer internal edges for a
  // body to catch on (Bullet's boxes jitter on a fine grid of triangles).
  std::vector<char> used(covered);
  const auto corner = [&](std::size_t i, std::size_t j) -> Eigen::Vector3f {
    const Eigen::Vector2d c =
        extent.min() + Eigen::Vector2d(static_cast<double>(i) * cell, static_cast<double>(j) * cell);
    return (c.x() * e1 + c.y() * e2 + floor_height * up).cast<float>();
  };
  for (std::size_t j = 0; j < nv; ++j)
    for (std::size_t i = 0; i < nu; ++i) {
      if (used[i * nv + j]) continue;
      std::size_t i1 = i + 1;
      while (i1 < nu && !used[i1 * nv + j]) ++i1;
      std::size_t j1 = j + 1;
      const auto row_free = [&](std::size_t row) {
        for (std::size_t k = i; k < i1; ++k)
          if (used[k * nv + row]) return false;
        return true;
      };
      while (j1 < nv && row_free(j1)) ++j1;
      for (std::size_t k = i; k < i1; ++k)
        for (std::size_t m = j; m < j1; ++m) used[k * nv + m] = 1;
      const auto base = static_cast<std::uint32_t>(patches.vertices.size());
      patches.vertices.insert(patches.vertices.end(),
                              {corner(i, j), corner(i1, j), corner(i1, j1), corner(i, j1)});
      // Counter-clockwise seen from above (e1 x e2 = up).
      patches.triangles.push_back({base, base + 1, base + 2});
      patches.triangles.push_back({base, base + 2, base + 3});
    }
  return patches;
}

SimulationResult simulate(const Scenario& scenario, const TriangleMesh& scene) {
  World world(scenario, scene);
  return world.run();
}

}  // namespace locard::sim
