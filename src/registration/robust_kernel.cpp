#include <locard/registration/robust_kernel.hpp>

namespace locard {

std::string_view to_string(RobustKernelType type) {
  switch (type) {
    case RobustKernelType::None:
      return "none";
    case RobustKernelType::Huber:
      return "huber";
    case RobustKernelType::Tukey:
      return "tukey";
    case RobustKernelType::GemanMcClure:
      return "geman-mcclure";
  }
  return "none";
}

std::optional<RobustKernelType> parse_robust_kernel(std::string_view name) {
  if (name == "none") return RobustKernelType::None;
  if (name == "huber") return RobustKernelType::Huber;
  if (name == "tukey") return RobustKernelType::Tukey;
  if (name == "geman-mcclure" || name == "gm") return RobustKernelType::GemanMcClure;
  return std::nullopt;
}

}  // namespace locard
