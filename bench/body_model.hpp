// A BVH skeleton as a body for the IK benchmarks: every BVH joint a ball joint (rest rotation
// identity, offsets from OFFSET, in metres), the root floating, six effectors (hips, hands, feet,
// head), human joint ranges per joint class, and the pieces of the single-chain stack (spine ->
// head, an arm per side from the collar, a leg per side from the hip). No ikchain::Tree here: the
// tree is built from this in body_tree.cpp, so this part needs only the chain API.
//
// Params (the tree's layout with a floating root): [0, 3) the root's translation (m, base space),
// then 3 per joint in joint order: its rotation vector relative to rest (R_j = exp(r_j)), so the
// recording's local rotations give the params directly and FK reproduces the recording.
#pragma once
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "bvh.hpp"
#include "ikchain/chain.hpp"

namespace body {

// Joint classes by their place in the skeleton (not by name: CMU's "LeftShoulder" is a collar,
// Boxing_Toes' "LeftShoulder" the glenohumeral joint).
enum class JointClass : int {
  kRoot, kPelvis, kHip, kKnee, kAnkle, kToe, kSpine, kNeck, kHead, kCollar, kShoulder, kElbow, kWrist,
  kFinger, kOther,
};
constexpr int kJointClassCount = 15;
const char* to_string(JointClass c);

// A class's range: the bone's swing away from its rest direction (a cone, deg) and the twist about
// it (deg), as ikchain::JointLimits holds them (twist_axis = the bone's rest direction).
struct Range {
  double cone_deg;
  double twist_min_deg;
  double twist_max_deg;
};
// The table the bench uses (body_model.cpp, docs/benchmarks.md "Body replay": joint ranges).
Range range_of(JointClass c);

enum Effector : int { kHips = 0, kLeftHand, kRightHand, kLeftFoot, kRightFoot, kHead, kEffectorCount };
const char* to_string(Effector e);

struct EffectorSpec {
  int joint = 0;
  glm::dvec3 offset_m{0.0};  // in the joint's frame
};

// One chain of the stack: consecutive joints (each the previous one's child), solved in the frame
// of `base_joint` (the first joint's parent) with its tip on `effector`.
struct ChainSpec {
  std::string name;
  std::vector<int> joints;
  int base_joint = 0;
  Effector effector = kHead;
};

struct Model {
  std::string name;
  double metres_per_unit = 1.0;
  int joint_count = 0;
  std::vector<std::string> joint_names;
  std::vector<int> parent;
  std::vector<glm::dvec3> offset_m;     // offset_in_parent (root: its OFFSET, the translation params add to it)
  std::vector<JointClass> joint_class;
  std::vector<ikchain::JointLimits> limits;  // none on the root
  EffectorSpec effectors[kEffectorCount];
  std::vector<ChainSpec> chains;        // solve order: spine -> head, arms, legs
  int dof_count() const { return 3 + 3 * joint_count; }
  int dof_offset(int joint) const { return 3 + 3 * joint; }
};

// Builds the model; false with `error` when a needed joint (hands, feet, head) is not found.
bool make_model(const bvh::Clip& clip, const std::string& name, double metres_per_unit, Model& out,
                std::string& error);

// The recorded pose of `frame` as params.
void recorded_params(const bvh::Clip& clip, const Model& m, int frame, double* params);

struct Pose {
  std::vector<glm::dvec3> origins;      // per joint, m
  std::vector<glm::dquat> orientations;
};
void forward_kinematics(const Model& m, const double* params, Pose& pose);
glm::dvec3 effector_position(const Model& m, const Pose& pose, int e);
glm::dquat effector_orientation(const Model& m, const Pose& pose, int e);

// The rig the coupled tree solvers get (body_tree.cpp; docs/benchmarks.md "Body replay": the
// rig), as a game developer would set up a full-body IK character, from the skeleton alone:
// - a motion cost per joint class (ikchain::TreeJointDesc::motion_cost): the trunk (spine, neck,
//   collars) kTrunkMotionCost, every other joint 1. The limbs serve the hands first; the trunk
//   moves only as much as the goals need (a coupled solve otherwise bends the spine toward every
//   hand: the minimum-norm step favours the joints with the longest levers).
// - a posture task: neutral_params() at posture_stiffness_of() per class.
constexpr double kTrunkMotionCost = 10.0;
double motion_cost_of(JointClass c);
// Per class, the share of the remaining way to the neutral pose one posture step closes: the
// trunk and head 1 (they hold themselves upright), the arms 0.1 (drawn down gently), every other
// joint 0. The legs have none: their ball knees would bend sideways toward a straighter leg.
double posture_stiffness_of(JointClass c);
// The neutral standing pose: the rest pose with each upper arm hanging kNeutralArmDeg out from
// the body (from the skeleton's own rest directions; CMU's rest is a T-pose, arms along +-X).
constexpr double kNeutralArmDeg = 10.0;
void neutral_params(const Model& m, double* params);

// Swing (of the twist axis) and twist of joint j's rotation vector, degrees (so3::swing_twist,
// the decomposition the core's limits use).
void swing_twist_deg(const Model& m, int joint, const double* params, double& swing, double& twist);
// Joints outside their limits by more than slack_rad (the core's within_limits on a one-joint
// chain of each); returns how many.
int count_limit_violations(const Model& m, const double* params, double slack_rad = 1e-6);

}  // namespace body
