// Variant-call argument conversion: an int arriving for a float parameter is converted by value.
#include "binding/variant_args.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <limits>

namespace ikchain::gdx {
namespace {

ScalarVariant of_int(int64_t i) {
  ScalarVariant v;
  v.type = uint32_t(VariantType::Int);
  v.i = i;
  return v;
}
ScalarVariant of_float(double f) {
  ScalarVariant v;
  v.type = uint32_t(VariantType::Float);
  v.f = f;
  return v;
}
ScalarVariant of_bool(bool b) {
  ScalarVariant v;
  v.type = uint32_t(VariantType::Bool);
  v.b = b;
  return v;
}

TEST(VariantArgs, IntForFloatParameterConvertsByValue) {
  double out = -1.0;
  ASSERT_TRUE(scalar_to_double(of_int(1), out));
  EXPECT_EQ(out, 1.0);
  // Not the int's bits seen as a double (that would be 4.9e-324).
  int64_t bits = 1;
  double reinterpreted;
  std::memcpy(&reinterpreted, &bits, sizeof(double));
  EXPECT_NE(out, reinterpreted);
  ASSERT_TRUE(scalar_to_double(of_int(-7), out));
  EXPECT_EQ(out, -7.0);
}

TEST(VariantArgs, FloatForFloatParameter) {
  double out = 0.0;
  ASSERT_TRUE(scalar_to_double(of_float(1e-4), out));
  EXPECT_EQ(out, 1e-4);
}

TEST(VariantArgs, BoolForNumbers) {
  double d = 0;
  int64_t i = 0;
  ASSERT_TRUE(scalar_to_double(of_bool(true), d));
  ASSERT_TRUE(scalar_to_int64(of_bool(true), i));
  EXPECT_EQ(d, 1.0);
  EXPECT_EQ(i, 1);
}

TEST(VariantArgs, FloatForIntParameterTruncatesTowardZero) {
  int64_t out = 0;
  ASSERT_TRUE(scalar_to_int64(of_float(64.9), out));
  EXPECT_EQ(out, 64);
  ASSERT_TRUE(scalar_to_int64(of_float(-2.5), out));
  EXPECT_EQ(out, -2);
}

TEST(VariantArgs, NonFiniteFloatForIntIsDefined) {
  int64_t out = 5;
  ASSERT_TRUE(scalar_to_int64(of_float(std::nan("")), out));
  EXPECT_EQ(out, 0);
  ASSERT_TRUE(scalar_to_int64(of_float(HUGE_VAL), out));
  EXPECT_EQ(out, std::numeric_limits<int64_t>::max());
  ASSERT_TRUE(scalar_to_int64(of_float(-HUGE_VAL), out));
  EXPECT_EQ(out, std::numeric_limits<int64_t>::min());
}

TEST(VariantArgs, NumbersForBoolParameter) {
  bool out = false;
  ASSERT_TRUE(scalar_to_bool(of_int(2), out));
  EXPECT_TRUE(out);
  ASSERT_TRUE(scalar_to_bool(of_float(0.0), out));
  EXPECT_FALSE(out);
}

TEST(VariantArgs, NonScalarsAreRejected) {
  ScalarVariant s;
  s.type = uint32_t(VariantType::String);
  double d = 3.0;
  int64_t i = 3;
  bool b = true;
  EXPECT_FALSE(scalar_to_double(s, d));
  EXPECT_FALSE(scalar_to_int64(s, i));
  EXPECT_FALSE(scalar_to_bool(s, b));
  EXPECT_EQ(d, 3.0);  // untouched on failure
  s.type = uint32_t(VariantType::Nil);
  EXPECT_FALSE(scalar_to_double(s, d));
}

}  // namespace
}  // namespace ikchain::gdx
