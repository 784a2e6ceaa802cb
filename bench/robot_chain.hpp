// A robot arm from a URDF, as tools/urdf_chain.py describes it (see that file for the format), built
// twice: as an ikchain::Chain from the folded joints, and as a KDL::Chain from the URDF joints as
// written (one KDL segment per URDF joint, the way kdl_parser builds it). The two constructions share
// nothing but the numbers in the file, so equal forward kinematics checks the mapping of URDF's
// frames onto ours (and the tool's folding of fixed joints). Used by bench/robots_bench.cpp and
// tests/robots/.
//
// URDF -> ikchain: joint i's origin (xyz, then rotation) is offset_translation[i] (in the parent
// joint's frame) and rest_rotation[i]; its axis in the joint frame is axis[i] (chain.hpp's
// convention: the offset before the rotation, both before the joint's own motion). A prismatic
// joint slides its successors along the axis, as URDF's child frame does. The fixed joints after the
// last moving one are the tip (tool) frame.
#pragma once
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <kdl/chain.hpp>
#include <kdl/frames.hpp>

#include "ikchain/ikchain.hpp"

namespace robots {

struct UrdfSegment {  // a URDF joint as written
  std::string name, type;                 // fixed, revolute, continuous, prismatic
  double xyz[3], rpy[3], axis[3];         // origin (m, rad) and axis (joint frame)
  double lower = NAN, upper = NAN;        // rad or m; nan for fixed and continuous joints
};

struct RobotJoint {  // a moving joint, the fixed joints before it folded into its origin
  std::string name, type;
  glm::dvec3 origin_translation{0.0};     // m, in the parent joint's frame
  glm::dquat origin_rotation{1.0, 0.0, 0.0, 0.0};
  glm::dvec3 axis{0.0, 0.0, 1.0};         // unit, in the joint frame
  double lower = NAN, upper = NAN;        // nan: continuous (no limits)
  bool limited() const { return std::isfinite(lower) && std::isfinite(upper); }
  bool prismatic() const { return type == "prismatic"; }
};

struct RobotDescription {
  std::string name, base, tip;
  std::vector<UrdfSegment> segments;
  std::vector<RobotJoint> joints;
  glm::dvec3 tool_translation{0.0};
  glm::dquat tool_rotation{1.0, 0.0, 0.0, 0.0};
};

// Reads tools/urdf_chain.py's output. Empty string on success, else what is wrong (file:line).
inline std::string read_robot(const std::string& path, RobotDescription& out) {
  std::ifstream f(path);
  if (!f) return "cannot open " + path;
  out = RobotDescription();
  bool have_tool = false;
  int line_number = 0;
  for (std::string line; std::getline(f, line);) {
    ++line_number;
    std::istringstream in(line);
    std::string key;
    if (!(in >> key) || key[0] == '#') continue;
    const std::string where = path + ":" + std::to_string(line_number) + ": ";
    std::vector<std::string> words;
    for (std::string w; in >> w;) words.push_back(w);
    // strtod, not operator>>: the file spells a continuous joint's limits "nan".
    auto numbers = [&](size_t first, size_t count, double* dst) {
      if (words.size() != first + count) return false;
      for (size_t i = 0; i < count; ++i) {
        char* end = nullptr;
        dst[i] = std::strtod(words[first + i].c_str(), &end);
        if (end == words[first + i].c_str() || *end != '\0') return false;
      }
      return true;
    };
    if (key == "robot" && words.size() == 1) {
      out.name = words[0];
    } else if (key == "base" && words.size() == 1) {
      out.base = words[0];
    } else if (key == "tip" && words.size() == 1) {
      out.tip = words[0];
    } else if (key == "segment" && words.size() >= 2) {
      UrdfSegment s;
      s.name = words[0];
      s.type = words[1];
      double v[11];
      if (!numbers(2, 11, v)) return where + "segment: expected name type and 11 numbers";
      for (int i = 0; i < 3; ++i) {
        s.xyz[i] = v[i];
        s.rpy[i] = v[3 + i];
        s.axis[i] = v[6 + i];
      }
      s.lower = v[9];
      s.upper = v[10];
      out.segments.push_back(s);
    } else if (key == "joint" && words.size() >= 2) {
      RobotJoint j;
      j.name = words[0];
      j.type = words[1];
      if (j.type != "revolute" && j.type != "continuous" && j.type != "prismatic")
        return where + "joint type " + j.type + " is not revolute, continuous or prismatic";
      double v[12];
      if (!numbers(2, 12, v)) return where + "joint: expected name type and 12 numbers";
      j.origin_translation = glm::dvec3(v[0], v[1], v[2]);
      j.origin_rotation = glm::dquat(v[3], v[4], v[5], v[6]);
      j.axis = glm::dvec3(v[7], v[8], v[9]);
      j.lower = v[10];
      j.upper = v[11];
      if (j.type != "continuous" && !j.limited()) return where + "a " + j.type + " joint needs finite limits";
      out.joints.push_back(j);
    } else if (key == "tool") {
      double v[7];
      if (!numbers(0, 7, v)) return where + "tool: expected 7 numbers";
      out.tool_translation = glm::dvec3(v[0], v[1], v[2]);
      out.tool_rotation = glm::dquat(v[3], v[4], v[5], v[6]);
      have_tool = true;
    } else {
      return where + "unknown record '" + key + "'";
    }
  }
  if (out.joints.empty()) return path + ": no joint records";
  if (!have_tool) return path + ": no tool record";
  return "";
}

// The ikchain chain: one hinge (revolute, continuous) or prismatic joint per moving URDF joint,
// with the URDF limits (none for continuous joints), and the tool frame as the tip frame.
inline ikchain::Message build_ikchain(const RobotDescription& robot, ikchain::Chain& out) {
  ikchain::ChainBuilder b;
  for (const RobotJoint& rj : robot.joints) {
    ikchain::JointDesc j;
    j.type = rj.prismatic() ? ikchain::JointType::kPrismatic : ikchain::JointType::kHinge;
    j.offset_translation = rj.origin_translation;
    j.rest_rotation = rj.origin_rotation;
    j.axis = rj.axis;
    if (rj.limited() && rj.prismatic()) {
      j.limits.has_slide_limit = true;
      j.limits.slide_min = rj.lower;
      j.limits.slide_max = rj.upper;
    } else if (rj.limited()) {
      j.limits.has_hinge_limit = true;
      j.limits.hinge_min = rj.lower;
      j.limits.hinge_max = rj.upper;
    }
    b.add_joint(j);
  }
  b.set_tip_frame(robot.tool_translation, robot.tool_rotation);
  return b.build(out).message;
}

// The KDL chain from the URDF joints as written (fixed joints are KDL::Joint::None segments),
// following kdl_parser: the joint sits at the origin with its axis turned into the parent frame,
// and the segment's tip is the origin frame (KDL's Segment stores it relative to the joint's pose
// at 0). Only the path's joints are segments, so segment tips past the last moving joint end at
// the tip link: the tool frame.
inline KDL::Chain build_kdl(const RobotDescription& robot) {
  KDL::Chain chain;
  for (const UrdfSegment& s : robot.segments) {
    const KDL::Frame origin(KDL::Rotation::RPY(s.rpy[0], s.rpy[1], s.rpy[2]),
                            KDL::Vector(s.xyz[0], s.xyz[1], s.xyz[2]));
    KDL::Joint joint(s.name, KDL::Joint::None);
    if (s.type != "fixed") {
      KDL::Vector axis(s.axis[0], s.axis[1], s.axis[2]);
      axis.Normalize();
      joint = KDL::Joint(s.name, origin.p, origin.M * axis,
                         s.type == "prismatic" ? KDL::Joint::TransAxis : KDL::Joint::RotAxis);
    }
    chain.addSegment(KDL::Segment(s.name, joint, origin));
  }
  return chain;
}

// A KDL frame as our (position, orientation) pair.
inline void from_kdl(const KDL::Frame& f, glm::dvec3& position, glm::dquat& orientation) {
  position = glm::dvec3(f.p.x(), f.p.y(), f.p.z());
  double x, y, z, w;
  f.M.GetQuaternion(x, y, z, w);
  orientation = glm::dquat(w, x, y, z);
}

// Angle between two orientations (rad, in [0, pi]).
inline double rotation_distance(const glm::dquat& a, const glm::dquat& b) {
  const glm::dquat delta = glm::normalize(a) * glm::conjugate(glm::normalize(b));
  // atan2 of the vector part's length and |w|: accurate near 0, unlike acos(|dot|).
  const double s = glm::length(glm::dvec3(delta.x, delta.y, delta.z));
  return 2.0 * std::atan2(s, std::abs(delta.w));
}

// The middle of each joint's limits (0 for a continuous joint): where the bench starts every solve.
inline Eigen::VectorXd middle_of_limits(const RobotDescription& robot) {
  Eigen::VectorXd q(robot.joints.size());
  for (size_t i = 0; i < robot.joints.size(); ++i)
    q[i] = robot.joints[i].limited() ? 0.5 * (robot.joints[i].lower + robot.joints[i].upper) : 0.0;
  return q;
}

// A uniformly random joint vector within the limits ([-pi, pi] for a continuous joint).
template <class Rng>
void random_in_limits(const RobotDescription& robot, Rng& rng, Eigen::VectorXd& q) {
  for (size_t i = 0; i < robot.joints.size(); ++i) {
    const RobotJoint& j = robot.joints[i];
    const double lo = j.limited() ? j.lower : -3.14159265358979323846;
    const double hi = j.limited() ? j.upper : 3.14159265358979323846;
    q[i] = std::uniform_real_distribution<double>(lo, hi)(rng);
  }
}

// True when every limited joint is within [lower - slack, upper + slack].
inline bool within_urdf_limits(const RobotDescription& robot, const Eigen::VectorXd& q, double slack) {
  for (size_t i = 0; i < robot.joints.size(); ++i) {
    const RobotJoint& j = robot.joints[i];
    if (!std::isfinite(q[i])) return false;
    if (j.limited() && (q[i] < j.lower - slack || q[i] > j.upper + slack)) return false;
  }
  return true;
}

}  // namespace robots
