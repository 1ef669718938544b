// RANSAC global alignment over correspondences; the algorithm is described in ransac.hpp.
#include <locard/registration/ransac.hpp>

#include <locard/core/error.hpp>
#include <locard/core/kdtree.hpp>
#include <locard/registration/rigid_transform.hpp>

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace locard {
namespace {

// Counter-based generator: SplitMix64 (Steele, Lea, Flood 2014) keyed by (seed, hypothesis).
// The n-th number of hypothesis h is a pure function of (seed, h, n), so hypotheses can run
// on any thread in any order and still draw the same samples.
class HypothesisRng {
 public:
  HypothesisRng(std::uint64_t seed, std::uint64_t hypothesis)
      : state_(mix(seed ^ mix(hypothesis + 0x632BE59BD9B4E019ull))) {}
  std::uint64_t next() {
    state_ += 0x9E3779B97F4A7C15ull;
    return mix(state_);
  }
  // Uniform in [0, n) by multiply-shift on 32 random bits (Lemire 2019); the bias, at most
  // n / 2^32, is irrelevant for correspondence counts.
  std::uint32_t below(std::uint32_t n) {
    return static_cast<std::uint32_t>(((next() >> 32) * static_cast<std::uint64_t>(n)) >> 32);
  }

 private:
  static std::uint64_t mix(std::uint64_t z) {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  std::uint64_t state_;
};

struct Candidate {
  std::size_t inliers = 0;
  double sse = 0.0;  // sum of squared inlier distances
  std::size_t hypothesis = std::numeric_limits<std::size_t>::max();
  Isometry3d T = Isometry3d::Identity();
  bool valid() const { return inliers > 0; }
  // The total order of ransac.hpp: more inliers, then lower RMSE, then smaller h.
  bool better_than(const Candidate& o) const {
    if (inliers != o.inliers) return inliers > o.inliers;
    if (!valid()) return false;
    // Equal counts: compare sse (same denominator, so RMSE order == SSE order).
    if (sse != o.sse) return sse < o.sse;
    return hypothesis < o.hypothesis;
  }
};

struct BlockOutcome {
  Candidate best;
  std::size_t checked = 0;
};

struct Problem {
  std::vector<Eigen::Vector3d> source;  // correspondence endpoints, centred
  std::vector<Eigen::Vector3d> target;
  double threshold_sq = 0.0;
};

// Inliers of T over all correspondences (and the sum of their squared distances).
std::pair<std::size_t, double> score(const Problem& p, const Isometry3d& T) {
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d t = T.translation();
  std::size_t inliers = 0;
  double sse = 0.0;
  const std::size_t n = p.source.size();
  for (std::size_t i = 0; i < n; ++i) {
    const double d2 = (R * p.source[i] + t - p.target[i]).squaredNorm();
    if (d2 <= p.threshold_sq) {
      ++inliers;
      sse += d2;
    }
  }
  return {inliers, sse};
}

// One hypothesis: sample, checks, Kabsch, score. Returns an invalid candidate when rejected.
Candidate run_hypothesis(const Problem& p, const RansacOptions& o, std::size_t h) {
  const auto n = static_cast<std::uint32_t>(p.source.size());
  HypothesisRng rng(o.seed, h);
  std::array<std::uint32_t, 3> idx{};
  idx[0] = rng.below(n);
  do idx[1] = rng.below(n); while (idx[1] == idx[0]);
  do idx[2] = rng.below(n); while (idx[2] == idx[0] || idx[2] == idx[1]);

  // Edge-length check: a rigid motion preserves |s_a - s_b|.
  if (o.edge_length_ratio > 0.0) {
    for (int a = 0; a < 3; ++a) {
      const int b = (a + 1) % 3;
      const double ls = (p.source[idx[a]] - p.source[idx[b]]).norm();
      const double lt = (p.target[idx[a]] - p.target[idx[b]]).norm();
      if (std::min(ls, lt) < o.edge_length_ratio * std::max(ls, lt)) return {};
    }
  }
  const std::array<Eigen::Vector3d, 3> s{p.source[idx[0]], p.source[idx[1]], p.source[idx[2]]};
  const std::array<Eigen::Vector3d, 3> t{p.target[idx[0]], p.target[idx[1]], p.target[idx[2]]};
  const auto T = estimate_rigid_transform(s, t);
  if (!T) return {};
  // Distance check on the sample itself.
  for (int a = 0; a < 3; ++a)
    if ((*T * s[a] - t[a]).squaredNorm() > p.threshold_sq) return {};
  Candidate c;
  std::tie(c.inliers, c.sse) = score(p, *T);
  c.hypothesis = h;
  c.T = *T;
  return c;
}

// Hypotheses needed to draw one all-inlier sample with probability `confidence` when a
// fraction w of the correspondences are inliers: log(1 - p) / log(1 - w^3).
std::size_t required_hypotheses(double w, double confidence, std::size_t cap) {
  if (confidence >= 1.0) return cap;
  const double w3 = w * w * w;
  if (w3 >= 1.0) return 1;
  const double denom = std::log1p(-w3);
  if (!(denom < 0.0)) return cap;
  const double n = std::ceil(std::log1p(-confidence) / denom);
  return n >= static_cast<double>(cap) ? cap : std::max<std::size_t>(1, static_cast<std::size_t>(n));
}

Eigen::Vector3d centroid_of(const std::vector<Eigen::Vector3f>& pts, std::size_t& finite) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  finite = 0;
  for (const auto& p : pts)
    if (p.allFinite()) {
      sum += p.cast<double>();
      ++finite;
    }
  return finite ? (sum / static_cast<double>(finite)).eval() : sum;
}

void check_options(const RansacOptions& o) {
  const auto bad = [](const std::string& what) { throw InputError("RANSAC options: " + what); };
  if (!(o.max_correspondence_distance > 0.0) || !std::isfinite(o.max_correspondence_distance))
    bad(fmt::format("max_correspondence_distance must be a positive number of metres, got {}",
                    o.max_correspondence_distance));
  if (!(o.edge_length_ratio >= 0.0 && o.edge_length_ratio < 1.0))
    bad(fmt::format("edge_length_ratio must be in [0, 1), got {}", o.edge_length_ratio));
  if (!(o.confidence > 0.0 && o.confidence <= 1.0))
    bad(fmt::format("confidence must be in (0, 1], got {}", o.confidence));
  if (o.max_iterations == 0) bad("max_iterations must be at least 1");
  if (o.refine_iterations < 0) bad("refine_iterations must be >= 0");
}

// --- hypotheses, in fixed blocks: the best candidate (invalid when none passed the checks);
// counts drawn and checked hypotheses into the result.
Candidate draw_hypotheses(const Problem& p, const RansacOptions& options, RansacResult& result) {
  const std::size_t K = p.source.size();
  Candidate best;
  std::size_t needed = options.max_iterations;
  std::size_t drawn = 0;
  std::size_t block_size = kRansacFirstBlock;
  while (drawn < needed) {
    const std::size_t begin = drawn;
    const std::size_t end = std::min(begin + block_size, options.max_iterations);
    block_size = std::min(2 * block_size, kRansacBlock);
    const BlockOutcome block = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(begin, end, 16), BlockOutcome{},
        [&](const tbb::blocked_range<std::size_t>& r, BlockOutcome acc) {
          for (std::size_t h = r.begin(); h != r.end(); ++h) {
            Candidate c = run_hypothesis(p, options, h);
            if (!c.valid()) continue;
            ++acc.checked;
            if (c.better_than(acc.best)) acc.best = c;
          }
          return acc;
        },
        [](BlockOutcome a, const BlockOutcome& b) {
          a.checked += b.checked;
          if (b.best.better_than(a.best)) a.best = b.best;
          return a;
        });
    drawn = end;
    result.hypotheses_checked += block.checked;
    if (block.best.better_than(best)) best = block.best;
    if (best.valid())
      needed = std::min(needed, required_hypotheses(static_cast<double>(best.inliers) / K,
                                                    options.confidence,
                                                    options.max_iterations));
  }
  result.hypotheses = drawn;
  return best;
}

// --- polish: Kabsch on the inliers, re-select, repeat (while the inliers do not shrink and
// still change). Returns the polished pose; `inliers` its inlier correspondences.
Isometry3d polish(const Problem& p, const Isometry3d& T_start, int refine_iterations,
                  std::vector<std::uint32_t>& inliers) {
  Isometry3d T_c = T_start;
  std::vector<std::uint32_t> previous;
  const std::size_t K = p.source.size();
  const auto select_inliers = [&](const Isometry3d& T, std::vector<std::uint32_t>& out) {
    out.clear();
    for (std::uint32_t i = 0; i < K; ++i)
      if ((T * p.source[i] - p.target[i]).squaredNorm() <= p.threshold_sq) out.push_back(i);
  };
  select_inliers(T_c, inliers);
  for (int it = 0; it < refine_iterations; ++it) {
    std::vector<Eigen::Vector3d> s, t;
    s.reserve(inliers.size());
    t.reserve(inliers.size());
    for (const std::uint32_t i : inliers) {
      s.push_back(p.source[i]);
      t.push_back(p.target[i]);
    }
    const auto T = estimate_rigid_transform(s, t);
    if (!T) break;
    std::vector<std::uint32_t> next;
    select_inliers(*T, next);
    if (next.size() < inliers.size()) break;  // keep the better estimate
    T_c = *T;
    previous.swap(inliers);
    inliers.swap(next);
    if (inliers == previous) break;
  }
  return T_c;
}

struct Fit {
  std::size_t count = 0;
  double sse = 0.0;
};

// --- fitness of the whole source cloud against the target cloud (both centred: cs, ct): the
// source points with a target point within max_distance under T_c, and their squared errors.
Fit cloud_fitness(const PointCloud& source, const PointCloud& target, const Eigen::Vector3d& cs,
                  const Eigen::Vector3d& ct, const Isometry3d& T_c, std::size_t target_finite,
                  double max_distance) {
  std::vector<Eigen::Vector3f> tpts;
  tpts.reserve(target_finite);
  for (const auto& q : target.positions)
    if (q.allFinite()) tpts.push_back((q.cast<double>() - ct).cast<float>());
  const KdTree tree(std::move(tpts));
  const float max_d = static_cast<float>(max_distance);
  return tbb::parallel_deterministic_reduce(
      tbb::blocked_range<std::size_t>(0, source.size(), 1024), Fit{},
      [&](const tbb::blocked_range<std::size_t>& r, Fit acc) {
        Neighbor nb;
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          const Eigen::Vector3f& sp = source.positions[i];
          if (!sp.allFinite()) continue;
          const Eigen::Vector3d q = T_c * (sp.cast<double>() - cs);
          if (!tree.nearest(q.cast<float>(), nb, max_d)) continue;
          ++acc.count;
          acc.sse += (q - tree.points()[nb.index].cast<double>()).squaredNorm();
        }
        return acc;
      },
      [](Fit a, const Fit& b) {
        a.count += b.count;
        a.sse += b.sse;
        return a;
      });
}

}  // namespace

RansacResult ransac_registration(const PointCloud& source, const PointCloud& target,
                                 std::span<const Correspondence> correspondences,
                                 const RansacOptions& options) {
  check_options(options);
  source.check_consistent();
  target.check_consistent();
  RansacResult result;
  result.seed = options.seed;

  std::size_t source_finite = 0, target_finite = 0;
  const Eigen::Vector3d cs = centroid_of(source.positions, source_finite);
  const Eigen::Vector3d ct = centroid_of(target.positions, target_finite);
  result.source_non_finite = source.size() - source_finite;
  result.target_non_finite = target.size() - target_finite;
  const auto too_small = [](const char* which, std::size_t finite, std::size_t dropped) {
    throw InputError(fmt::format(
        "RANSAC: the {} cloud has {} finite point{}{}; at least 3 are needed", which, finite,
        finite == 1 ? "" : "s",
        dropped ? fmt::format(" ({} with NaN/Inf coordinates dropped)", dropped) : ""));
  };
  if (source_finite < 3) too_small("source", source_finite, result.source_non_finite);
  if (target_finite < 3) too_small("target", target_finite, result.target_non_finite);

  Problem p;
  p.threshold_sq = options.max_correspondence_distance * options.max_correspondence_distance;
  p.source.reserve(correspondences.size());
  p.target.reserve(correspondences.size());
  for (std::size_t i = 0; i < correspondences.size(); ++i) {
    const Correspondence& c = correspondences[i];
    if (c.source >= source.size() || c.target >= target.size())
      throw InputError(fmt::format(
          "RANSAC: correspondence {} pairs source point {} with target point {}, but the clouds "
          "have {} and {} points",
          i, c.source, c.target, source.size(), target.size()));
    const Eigen::Vector3f& s = source.positions[c.source];
    const Eigen::Vector3f& t = target.positions[c.target];
    if (!s.allFinite() || !t.allFinite()) {
      ++result.dropped_correspondences;
      continue;
    }
    p.source.push_back(s.cast<double>() - cs);
    p.target.push_back(t.cast<double>() - ct);
  }
  const std::size_t K = p.source.size();
  result.correspondences = K;
  const auto to_world = [&](const Isometry3d& Tc) {
    Isometry3d T = Tc;
    T.translation() = Tc.translation() + ct - Tc.linear() * cs;
    return T;
  };
  if (K < 3) {
    result.reason = fmt::format("{} usable correspondence{}; RANSAC needs at least 3", K,
                                K == 1 ? "" : "s");
    return result;
  }

  const Candidate best = draw_hypotheses(p, options, result);
  const std::size_t drawn = result.hypotheses;
  if (!best.valid()) {
    result.reason = fmt::format(
        "none of {} hypotheses passed the edge-length and distance checks: the "
        "correspondences are inconsistent (wrong matches, or no overlap)",
        drawn);
    return result;
  }
  result.best_hypothesis = best.hypothesis;

  std::vector<std::uint32_t> inliers;
  const Isometry3d T_c = polish(p, best.T, options.refine_iterations, inliers);
  result.inlier_correspondences = inliers.size();
  result.inlier_ratio = static_cast<double>(inliers.size()) / static_cast<double>(K);
  result.T_target_source = to_world(T_c);

  const Fit fit = cloud_fitness(source, target, cs, ct, T_c, target_finite,
                                options.max_correspondence_distance);
  result.cloud_correspondences = fit.count;
  result.fitness = static_cast<double>(fit.count) / static_cast<double>(source_finite);
  result.inlier_rmse = fit.count ? std::sqrt(fit.sse / static_cast<double>(fit.count)) : 0.0;

  const std::size_t min_inliers = std::max<std::size_t>(3, options.min_inliers);
  if (result.inlier_correspondences < min_inliers) {
    result.reason = fmt::format(
        "the best hypothesis has {} inlier correspondence{} of {} (at least {} needed): no "
        "consistent alignment found",
        result.inlier_correspondences, result.inlier_correspondences == 1 ? "" : "s", K,
        min_inliers);
    return result;
  }
  if (result.fitness < options.min_fitness) {
    result.reason = fmt::format("fitness {:.4f} is below min_fitness {:.4f}", result.fitness,
                                options.min_fitness);
    return result;
  }
  result.success = true;
  return result;
}

}  // namespace locard
