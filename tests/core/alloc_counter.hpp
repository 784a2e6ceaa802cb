// Counts heap allocations made through operator new in this test binary, to prove the per-frame
// solve allocates nothing: take the count before and after, expect equality.
#pragma once
#include <cstddef>

namespace ikchain {
namespace test {
std::size_t allocation_count();
}  // namespace test
}  // namespace ikchain
