// The allocation counter's own check: the zero-allocation tests (solve_test, limits_test, ...) prove
// nothing if the counter misses allocations, which depends on the platform's interposition
// (glibc: this executable's malloc; Windows: the linker's --wrap; ASan: its allocator hook).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <memory>
#include <vector>

#include "alloc_counter.hpp"

namespace ikchain {
namespace {

TEST(AllocCounter, SeesOperatorNewAndEigenHeapMatrices) {
  const std::size_t before = test::allocation_count();
  auto v = std::make_unique<std::vector<double>>(100, 1.0);  // two: the vector object and its data
  EXPECT_GE(test::allocation_count(), before + 2);
  const std::size_t mid = test::allocation_count();
  Eigen::MatrixXd m = Eigen::MatrixXd::Identity(7, 7);  // Eigen's dynamic storage: std::malloc
  EXPECT_GE(test::allocation_count(), mid + 1);
  EXPECT_DOUBLE_EQ(m.trace() + (*v)[99], 8.0);
}

}  // namespace
}  // namespace ikchain
