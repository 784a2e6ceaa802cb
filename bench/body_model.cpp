#include "body_model.hpp"

#include <algorithm>
#include <cmath>

#include "ikchain/so3.hpp"

namespace body {

const char* to_string(JointClass c) {
  static const char* names[] = {"root", "pelvis", "hip", "knee", "ankle", "toe", "spine", "neck",
                                "head", "collar", "shoulder", "elbow", "wrist", "finger", "other"};
  return names[static_cast<int>(c)];
}

const char* to_string(Effector e) {
  static const char* names[] = {"hips", "left_hand", "right_hand", "left_foot", "right_foot", "head"};
  return names[e];
}

// Human joint ranges, relative to the BVH rest pose (CMU: a T-pose, arms along +-X, legs and spine
// along Y), as a cone on the bone's swing and a twist range about the bone. Sources: the usual
// clinical ranges of motion (AAOS), widened where a ball joint stands for a hinge whose flexion is
// measured as swing (knee: 0-160 deg flexion clinically; CMU's recorded knees reach 164 deg) and
// where BVH spreads one anatomical motion over two joints (CMU's LowerBack/Spine/Spine1, Neck/
// Neck1/Head). The rest pose is inside every range (params = 0 is feasible). The bench prints, per
// class, the largest recorded swing and twist and how many recorded frames leave these ranges.
Range range_of(JointClass c) {
  switch (c) {
    case JointClass::kRoot: return {180, -180, 180};       // unlimited: the floating root
    case JointClass::kPelvis: return {30, -30, 30};         // CMU LHipJoint/RHipJoint (recorded: 0)
    case JointClass::kHip: return {140, -80, 80};           // flexion 120-140, abduction 45; rotation +-45
    case JointClass::kKnee: return {170, -60, 60};          // flexion 160 (CMU: 164); tibial rotation
    case JointClass::kAnkle: return {80, -60, 60};          // dorsi/plantar 20/50, inversion 35
    case JointClass::kToe: return {90, -45, 45};
    case JointClass::kSpine: return {60, -60, 60};          // per BVH spine joint
    case JointClass::kNeck: return {80, -80, 80};           // cervical flexion 50-60, rotation 80
    case JointClass::kHead: return {80, -80, 80};
    case JointClass::kCollar: return {50, -50, 50};         // clavicle elevation/protraction
    case JointClass::kShoulder: return {175, -120, 120};    // from the T-pose: down 90, up 90, across 130
    case JointClass::kElbow: return {165, -120, 120};       // flexion 150; the forearm's pronation/supination
    case JointClass::kWrist: return {100, -90, 90};         // flexion 80, extension 70
    // CMU's finger and thumb channels (no effector depends on them) carry marker noise: 01_03
    // records 154 deg of swing and +-180 deg of twist there. Open, so the recording lies inside.
    case JointClass::kFinger: return {160, -180, 180};
    case JointClass::kOther: return {180, -180, 180};
  }
  return {180, -180, 180};
}

namespace {

const char* const kHandNames[2][2] = {{"LeftHand", "LeftWrist"}, {"RightHand", "RightWrist"}};
const char* const kFootNames[2][2] = {{"LeftFoot", "LeftAnkle"}, {"RightFoot", "RightAnkle"}};

int find_any(const bvh::Clip& clip, const char* const names[2]) {
  for (int k = 0; k < 2; ++k) {
    const int j = clip.find(names[k]);
    if (j >= 0) return j;
  }
  return -1;
}

bool is_ancestor(const std::vector<int>& parent, int a, int j) {  // a is j or above j
  for (; j >= 0; j = parent[j])
    if (j == a) return true;
  return false;
}

// Joints from `from` (exclusive) down to `to` (inclusive), root first.
std::vector<int> path_below(const std::vector<int>& parent, int from, int to) {
  std::vector<int> path;
  for (int j = to; j != from && j >= 0; j = parent[j]) path.push_back(j);
  std::reverse(path.begin(), path.end());
  return path;
}

}  // namespace

double motion_cost_of(JointClass c) {
  return (c == JointClass::kSpine || c == JointClass::kNeck || c == JointClass::kCollar) ? kTrunkMotionCost : 1.0;
}

double posture_stiffness_of(JointClass c) {
  switch (c) {
    case JointClass::kSpine:
    case JointClass::kNeck:
    case JointClass::kHead:
    case JointClass::kCollar: return 1.0;
    case JointClass::kShoulder:
    case JointClass::kElbow:
    case JointClass::kWrist: return 0.1;
    default: return 0.0;
  }
}

void neutral_params(const Model& m, double* params) {
  std::fill(params, params + m.dof_count(), 0.0);
  const double away = kNeutralArmDeg * ikchain::so3::kPi / 180.0;
  for (int j = 0; j < m.joint_count; ++j) {
    if (m.joint_class[j] != JointClass::kShoulder) continue;
    for (int c = 0; c < m.joint_count; ++c) {
      if (m.parent[c] != j) continue;
      // The upper arm's rest direction (the elbow's offset), turned down to hang kNeutralArmDeg
      // out from straight down, on its own side.
      const glm::dvec3 rest = glm::normalize(m.offset_m[c]);
      if (std::hypot(rest.x, rest.z) < 0.5) break;  // the rest pose's arm already hangs: keep it
      const glm::dvec3 side = glm::normalize(glm::dvec3(rest.x, 0.0, rest.z));
      const glm::dvec3 hang = std::cos(away) * glm::dvec3(0.0, -1.0, 0.0) + std::sin(away) * side;
      const glm::dvec3 axis = glm::cross(rest, hang);
      const double angle = std::atan2(glm::length(axis), glm::dot(rest, hang));
      const glm::dvec3 r = glm::normalize(axis) * angle;
      for (int d = 0; d < 3; ++d) params[m.dof_offset(j) + d] = r[d];
      break;
    }
  }
}

bool make_model(const bvh::Clip& clip, const std::string& name, double metres_per_unit, Model& m,
                std::string& error) {
  m = Model{};
  m.name = name;
  m.metres_per_unit = metres_per_unit;
  const int n = static_cast<int>(clip.joints.size());
  m.joint_count = n;
  for (const bvh::Joint& j : clip.joints) {
    m.joint_names.push_back(j.name);
    m.parent.push_back(j.parent);
    m.offset_m.push_back(j.offset * metres_per_unit);
  }
  const int hand[2] = {find_any(clip, kHandNames[0]), find_any(clip, kHandNames[1])};
  const int foot[2] = {find_any(clip, kFootNames[0]), find_any(clip, kFootNames[1])};
  const int head = clip.find("Head");
  if (hand[0] < 0 || hand[1] < 0 || foot[0] < 0 || foot[1] < 0 || head < 0) {
    error = name + ": needs LeftHand/LeftWrist, RightHand/RightWrist, LeftFoot/LeftAnkle, RightFoot/RightAnkle and Head";
    return false;
  }
  // The chest: the lowest joint above the head that is also above both hands.
  int chest = m.parent[head];
  while (chest > 0 && !(is_ancestor(m.parent, chest, hand[0]) && is_ancestor(m.parent, chest, hand[1])))
    chest = m.parent[chest];

  m.joint_class.assign(n, JointClass::kOther);
  m.joint_class[0] = JointClass::kRoot;
  for (int j : path_below(m.parent, 0, chest)) m.joint_class[j] = JointClass::kSpine;
  for (int j : path_below(m.parent, chest, head)) m.joint_class[j] = JointClass::kNeck;
  m.joint_class[head] = JointClass::kHead;
  for (int side = 0; side < 2; ++side) {
    const int h = hand[side], elbow = m.parent[h], shoulder = m.parent[elbow];
    for (int j : path_below(m.parent, chest, m.parent[shoulder])) m.joint_class[j] = JointClass::kCollar;
    if (m.parent[shoulder] != chest) m.joint_class[m.parent[shoulder]] = JointClass::kCollar;
    m.joint_class[shoulder] = JointClass::kShoulder;
    m.joint_class[elbow] = JointClass::kElbow;
    m.joint_class[h] = JointClass::kWrist;
    const int f = foot[side], knee = m.parent[f], hip = m.parent[knee];
    for (int j : path_below(m.parent, 0, hip)) m.joint_class[j] = JointClass::kPelvis;
    m.joint_class[hip] = JointClass::kHip;
    m.joint_class[knee] = JointClass::kKnee;
    m.joint_class[f] = JointClass::kAnkle;
    for (int j = 0; j < n; ++j) {
      if (j != h && is_ancestor(m.parent, h, j)) m.joint_class[j] = JointClass::kFinger;
      if (j != f && is_ancestor(m.parent, f, j)) m.joint_class[j] = JointClass::kToe;
    }
  }

  // Limits: twist_axis = the bone's rest direction (toward the child on the way to the head for
  // spine joints, else the first child, through zero-length children; the End Site for a leaf).
  m.limits.assign(n, ikchain::JointLimits{});
  for (int j = 1; j < n; ++j) {
    glm::dvec3 dir(0.0);
    for (int k = j; glm::length(dir) < 1e-9;) {
      std::vector<int> kids = clip.children(k);
      if (kids.empty()) {
        if (clip.joints[k].has_end_site) dir = clip.joints[k].end_site;
        break;
      }
      int next = kids[0];
      for (int c : kids)
        if (is_ancestor(m.parent, c, head)) next = c;
      dir = clip.joints[next].offset;
      k = next;
    }
    if (glm::length(dir) < 1e-9) dir = clip.joints[j].offset;
    if (glm::length(dir) < 1e-9) dir = glm::dvec3(0, 1, 0);
    const Range r = range_of(m.joint_class[j]);
    ikchain::JointLimits& l = m.limits[j];
    l.twist_axis = glm::normalize(dir);
    l.has_cone_limit = r.cone_deg < 180.0;
    l.cone_angle = glm::radians(r.cone_deg);
    l.has_twist_limit = r.twist_min_deg > -180.0 || r.twist_max_deg < 180.0;
    l.twist_min = glm::radians(r.twist_min_deg);
    l.twist_max = glm::radians(r.twist_max_deg);
  }

  m.effectors[kHips] = {0, glm::dvec3(0.0)};
  m.effectors[kLeftHand] = {hand[0], glm::dvec3(0.0)};
  m.effectors[kRightHand] = {hand[1], glm::dvec3(0.0)};
  m.effectors[kLeftFoot] = {foot[0], glm::dvec3(0.0)};
  m.effectors[kRightFoot] = {foot[1], glm::dvec3(0.0)};
  // The head effector: the top of the head (its End Site), with the head's orientation.
  m.effectors[kHead] = {head, clip.joints[head].has_end_site ? clip.joints[head].end_site * metres_per_unit
                                                             : glm::dvec3(0.0)};

  // The stack: spine -> head from the hips, each arm from its collar (below the chest), each leg
  // from below the hips.
  auto chain = [&](const std::string& cname, int from, int to, Effector e) {
    ChainSpec c;
    c.name = cname;
    c.joints = path_below(m.parent, from, to);
    c.base_joint = from;
    c.effector = e;
    m.chains.push_back(c);
  };
  chain("spine_head", 0, head, kHead);
  chain("left_arm", chest, hand[0], kLeftHand);
  chain("right_arm", chest, hand[1], kRightHand);
  chain("left_leg", 0, foot[0], kLeftFoot);
  chain("right_leg", 0, foot[1], kRightFoot);
  return true;
}

void recorded_params(const bvh::Clip& clip, const Model& m, int frame, double* params) {
  const double* values = clip.frame(frame);
  const glm::dvec3 t = bvh::local_translation(clip, 0, values) * m.metres_per_unit - m.offset_m[0];
  params[0] = t.x;
  params[1] = t.y;
  params[2] = t.z;
  for (int j = 0; j < m.joint_count; ++j) {
    const glm::dvec3 r = ikchain::so3::log(bvh::local_rotation(clip, j, values));
    const int o = m.dof_offset(j);
    params[o] = r.x;
    params[o + 1] = r.y;
    params[o + 2] = r.z;
  }
}

void forward_kinematics(const Model& m, const double* params, Pose& pose) {
  pose.origins.resize(m.joint_count);
  pose.orientations.resize(m.joint_count);
  for (int j = 0; j < m.joint_count; ++j) {
    const int o = m.dof_offset(j);
    const glm::dquat r = ikchain::so3::exp(glm::dvec3(params[o], params[o + 1], params[o + 2]));
    const int p = m.parent[j];
    if (p < 0) {
      pose.origins[j] = m.offset_m[j] + glm::dvec3(params[0], params[1], params[2]);
      pose.orientations[j] = r;
    } else {
      pose.origins[j] = pose.origins[p] + pose.orientations[p] * m.offset_m[j];
      pose.orientations[j] = pose.orientations[p] * r;
    }
  }
}

glm::dvec3 effector_position(const Model& m, const Pose& pose, int e) {
  const EffectorSpec& s = m.effectors[e];
  return pose.origins[s.joint] + pose.orientations[s.joint] * s.offset_m;
}

glm::dquat effector_orientation(const Model& m, const Pose& pose, int e) {
  return pose.orientations[m.effectors[e].joint];
}

void swing_twist_deg(const Model& m, int joint, const double* params, double& swing, double& twist) {
  const int o = m.dof_offset(joint);
  const glm::dquat q = ikchain::so3::exp(glm::dvec3(params[o], params[o + 1], params[o + 2]));
  glm::dquat s;
  double t = 0.0;
  ikchain::so3::swing_twist(q, m.limits[joint].twist_axis, s, t);
  swing = glm::degrees(glm::length(ikchain::so3::log(s)));
  twist = glm::degrees(t);
}

int count_limit_violations(const Model& m, const double* params, double slack_rad) {
  int count = 0;
  for (int j = 1; j < m.joint_count; ++j) {
    const ikchain::JointLimits& l = m.limits[j];
    if (!l.has_cone_limit && !l.has_twist_limit) continue;
    double swing = 0.0, twist = 0.0;
    swing_twist_deg(m, j, params, swing, twist);
    const double slack_deg = glm::degrees(slack_rad);
    if ((l.has_cone_limit && swing > glm::degrees(l.cone_angle) + slack_deg) ||
        (l.has_twist_limit && (twist < glm::degrees(l.twist_min) - slack_deg ||
                               twist > glm::degrees(l.twist_max) + slack_deg)))
      ++count;
  }
  return count;
}

}  // namespace body
