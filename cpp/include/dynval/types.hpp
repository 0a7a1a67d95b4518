// The index type of the core (Eigen's, signed).
#pragma once

#include <Eigen/Core>

namespace dynval {

using Index = Eigen::Index;

}  // namespace dynval
