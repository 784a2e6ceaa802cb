// Godot layouts <-> GLM (double) conversions: row-major Basis vs column-major GLM, quaternion
// component order, Transform3D composition. No engine needed.
#include "binding/math.hpp"

#include <gtest/gtest.h>

#include <cstddef>
#include <glm/gtc/matrix_transform.hpp>

#include "engine_api.gen.hpp"

namespace ikchain::gdx {
namespace {

TEST(BuiltinLayout, MatchesEngineConfiguration) {
  // real_t is float in this engine build: 3 floats, rows[3], basis + origin.
  EXPECT_FALSE(gen::kRealIsDouble);
  EXPECT_EQ(sizeof(Vector3), gen::kSize_Vector3);
  EXPECT_EQ(sizeof(Quaternion), gen::kSize_Quaternion);
  EXPECT_EQ(sizeof(Basis), gen::kSize_Basis);
  EXPECT_EQ(sizeof(Transform3D), gen::kSize_Transform3D);
  EXPECT_EQ(offsetof(Quaternion, w), 12u);  // Godot stores x, y, z, w
  EXPECT_EQ(offsetof(Transform3D, origin), 36u);
}

TEST(BasisConversion, RowMajorToColumnMajor) {
  Basis b;
  // rows[r] = (10r+0, 10r+1, 10r+2): element (r, c) = 10r + c.
  for (int r = 0; r < 3; ++r) b.rows[r] = Vector3{real_t(10 * r), real_t(10 * r + 1), real_t(10 * r + 2)};
  const glm::dmat3 m = to_glm(b);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) EXPECT_DOUBLE_EQ(m[c][r], 10.0 * r + c) << "row " << r << " col " << c;
}

TEST(BasisConversion, RoundTrip) {
  Basis b;
  b.rows[0] = {1, 2, 3};
  b.rows[1] = {4, 5, 6};
  b.rows[2] = {7, 8, 9};
  const Basis back = from_glm(to_glm(b));
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(component(back.rows[r], c), component(b.rows[r], c));
}

TEST(BasisConversion, RotationActsOnColumnVectorsLikeGodot) {
  // Godot: Basis(axis Z, +90deg) rows = [[0,-1,0],[1,0,0],[0,0,1]] and maps X to Y.
  Basis b;
  b.rows[0] = {0, -1, 0};
  b.rows[1] = {1, 0, 0};
  b.rows[2] = {0, 0, 1};
  const glm::dvec3 y = to_glm(b) * glm::dvec3(1, 0, 0);
  EXPECT_NEAR(y.x, 0.0, 1e-12);
  EXPECT_NEAR(y.y, 1.0, 1e-12);
  EXPECT_NEAR(y.z, 0.0, 1e-12);
}

TEST(QuaternionConversion, ComponentOrder) {
  const Quaternion q{0.1f, 0.2f, 0.3f, 0.9f};
  const glm::dquat g = to_glm(q);
  EXPECT_DOUBLE_EQ(g.x, double(0.1f));
  EXPECT_DOUBLE_EQ(g.y, double(0.2f));
  EXPECT_DOUBLE_EQ(g.z, double(0.3f));
  EXPECT_DOUBLE_EQ(g.w, double(0.9f));
  const Quaternion back = from_glm(g);
  EXPECT_EQ(back.x, q.x);
  EXPECT_EQ(back.y, q.y);
  EXPECT_EQ(back.z, q.z);
  EXPECT_EQ(back.w, q.w);
}

TEST(QuaternionConversion, AgreesWithBasis) {
  // 90deg about Z, both ways: the quaternion's matrix equals the Basis' matrix.
  const double h = std::sqrt(0.5);
  const glm::dquat q = to_glm(Quaternion{0, 0, real_t(h), real_t(h)});
  Basis b;
  b.rows[0] = {0, -1, 0};
  b.rows[1] = {1, 0, 0};
  b.rows[2] = {0, 0, 1};
  const glm::dmat3 from_q = glm::mat3_cast(q);
  const glm::dmat3 from_b = to_glm(b);
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) EXPECT_NEAR(from_q[c][r], from_b[c][r], 1e-7);
}

TEST(Transform3DConversion, OriginAndComposition) {
  Transform3D t;
  t.basis.rows[0] = {0, -1, 0};  // 90deg about Z
  t.basis.rows[1] = {1, 0, 0};
  t.basis.rows[2] = {0, 0, 1};
  t.origin = {1, 2, 3};
  const glm::dmat4 m = to_glm(t);
  // Godot: t.xform(p) = basis * p + origin.
  const glm::dvec4 p = m * glm::dvec4(1, 0, 0, 1);
  EXPECT_NEAR(p.x, 1.0, 1e-12);
  EXPECT_NEAR(p.y, 3.0, 1e-12);
  EXPECT_NEAR(p.z, 3.0, 1e-12);
  EXPECT_DOUBLE_EQ(m[3][3], 1.0);
  EXPECT_DOUBLE_EQ(m[0][3], 0.0);
  // Inverse brings the point back (used for the target in the chain's base space).
  const glm::dvec4 q = glm::inverse(m) * p;
  EXPECT_NEAR(q.x, 1.0, 1e-12);
  EXPECT_NEAR(q.y, 0.0, 1e-12);
  const Transform3D back = from_glm(m);
  EXPECT_EQ(back.origin.x, 1.0f);
  EXPECT_EQ(back.origin.y, 2.0f);
  EXPECT_EQ(back.origin.z, 3.0f);
  EXPECT_EQ(back.basis.rows[0].y, -1.0f);
}

TEST(Finite, DetectsNaNAndInf) {
  EXPECT_TRUE(is_finite(glm::dvec3(1, 2, 3)));
  EXPECT_FALSE(is_finite(glm::dvec3(1, std::nan(""), 3)));
  EXPECT_FALSE(is_finite(glm::dquat(HUGE_VAL, 0, 0, 0)));
}

}  // namespace
}  // namespace ikchain::gdx
