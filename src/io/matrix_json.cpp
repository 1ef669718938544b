// Matrices as JSON rows (see matrix_json.hpp).
#include <locard/io/matrix_json.hpp>

namespace locard {

nlohmann::json matrix_json(const Eigen::MatrixXd& m) {
  nlohmann::json rows = nlohmann::json::array();
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (Eigen::Index c = 0; c < m.cols(); ++c) row.push_back(m(r, c));
    rows.push_back(row);
  }
  return rows;
}

nlohmann::json pose_json(const Isometry3d& T) { return matrix_json(T.matrix()); }

}  // namespace locard
