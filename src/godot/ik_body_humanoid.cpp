// IKBody::setup_humanoid(): the rig for Godot's SkeletonProfileHumanoid bone names (effectors at
// their levels, knee and elbow hinges, spine and neck cones).
#include "ik_body.hpp"

#include <string>
#include <string_view>

#include "binding/classes.hpp"
#include "binding/log.hpp"
#include "binding/math.hpp"
#include "ikchain/so3.hpp"
#include "ik_body_effector.hpp"
#include "ik_chain_joint.hpp"

namespace ikchain::godot {

namespace {

constexpr double kDeg = so3::kPi / 180.0;

// The bones setup_humanoid() needs: those SkeletonProfileHumanoid marks required (is_required()),
// which a retargeted import always has.
constexpr const char* kRequiredBones[] = {
    "Hips",         "Spine",         "Head",          "LeftUpperLeg",  "LeftLowerLeg",  "LeftFoot",
    "RightUpperLeg", "RightLowerLeg", "RightFoot",    "LeftShoulder",  "LeftUpperArm",  "LeftLowerArm",
    "LeftHand",     "RightShoulder", "RightUpperArm", "RightLowerArm", "RightHand"};
// The head's look spread (IKBodyEffector.look_shares) from the head down the spine; the profile's
// optional bones (Neck, UpperChest, Chest: a rig with fewer spine bones leaves them out) get a cone
// and a share when the skeleton has them, and the shares of those present are scaled to sum to 1.
struct LookShare {
  const char* bone;
  double share;
};
constexpr LookShare kLookShares[] = {
    {"Head", 0.35}, {"Neck", 0.25}, {"UpperChest", 0.15}, {"Chest", 0.15}, {"Spine", 0.1}};

// A new instance of one of our resource classes, held by the returned Variant.
gdx::Variant new_resource(const char* class_name, gdx::ObjectPtr& object) {
  const gdx::StringName name{std::string_view(class_name)};
  object = gdx::gde.classdb_construct_object2(name.ptr());
  return gdx::Variant::from_object(object);
}

// A bone's rest in skeleton space (the rests composed up its parents).
glm::dmat4 global_rest(const gdx::Skeleton3D& skel, int bone) {
  glm::dmat4 m(1.0);
  const int64_t count = skel.get_bone_count();
  for (int64_t steps = 0; bone >= 0 && steps <= count; ++steps) {
    m = gdx::to_glm(skel.get_bone_rest(bone)) * m;
    bone = int(skel.get_bone_parent(bone));
  }
  return m;
}

}  // namespace

bool IKBody::setup_humanoid() {
  const gdx::Skeleton3D skel = skeleton();
  if (!skel) {
    IKCHAIN_PRINT_ERROR("IKBody.setup_humanoid(): the parent is not a Skeleton3D; make IKBody a child of a Skeleton3D "
                        "that uses Godot's humanoid bone names (SkeletonProfileHumanoid). Nothing was changed.");
    return false;
  }
  std::string missing;
  for (const char* bone : kRequiredBones)
    if (skel.find_bone(gdx::String(bone)) < 0) missing += std::string(missing.empty() ? "" : ", ") + bone;
  if (!missing.empty()) {
    const std::string message =
        "IKBody.setup_humanoid(): the skeleton lacks the humanoid bones " + missing +
        " (SkeletonProfileHumanoid requires them; Chest, UpperChest and Neck may be missing); it needs Godot's "
        "humanoid names (retarget the model on import with a BoneMap). Nothing was changed.";
    IKCHAIN_PRINT_ERROR(message.c_str());
    return false;
  }
  auto bone_of = [&](const char* name) { return int(skel.find_bone(gdx::String(name))); };
  // The look spread names the head's ancestors down to the spine: only when they are the profile's
  // bones (extra bones in between, a twist bone say, would take the shares instead).
  bool look_chain = true;
  int b = bone_of("Head");
  for (const LookShare& link : kLookShares) {
    if (std::string_view(link.bone) != "Head" && bone_of(link.bone) < 0) continue;
    if (b != bone_of(link.bone)) look_chain = false;
    if (b >= 0) b = int(skel.get_bone_parent(b));
  }
  if (!look_chain)
    IKCHAIN_PRINT_WARNING("IKBody.setup_humanoid(): the bones from Head down to Spine are not SkeletonProfileHumanoid's "
                          "chain (Head, Neck, UpperChest, Chest, Spine, each the parent of the one before, those "
                          "present), so the head's look_shares are left empty (it looks alone); set them by hand.");

  // Effectors: contacts at level 1 (the hips only softly), hands at 2, the head's look at 3.
  struct EffectorSpec {
    const char* bone;
    int64_t priority;
    double position_weight, rotation_weight;
  };
  constexpr EffectorSpec kEffectors[] = {{"Hips", 1, 0.1, 0.1},     {"LeftFoot", 1, 1.0, 1.0},
                                         {"RightFoot", 1, 1.0, 1.0}, {"LeftHand", 2, 1.0, 0.0},
                                         {"RightHand", 2, 1.0, 0.0}, {"Head", 3, 0.0, 1.0}};
  gdx::Array effectors;
  for (const EffectorSpec& spec : kEffectors) {
    gdx::ObjectPtr object = nullptr;
    const gdx::Variant held = new_resource("IKBodyEffector", object);
    IKBodyEffector* e = IKBodyEffector::from_object(object);
    if (e == nullptr) return false;
    e->set_bone_name(gdx::String(spec.bone));
    e->set_priority(spec.priority);
    e->set_position_weight(spec.position_weight);
    e->set_rotation_weight(spec.rotation_weight);
    if (std::string_view(spec.bone) == "Head") {
      // Ready to look (turn on look_at): the turn spread over head, neck, upper chest, chest, spine.
      double total = 0.0;
      for (const LookShare& link : kLookShares)
        if (bone_of(link.bone) >= 0) total += link.share;
      gdx::Array shares;
      for (const LookShare& link : kLookShares)
        if (look_chain && bone_of(link.bone) >= 0) shares.push_back(gdx::Variant(link.share / total));
      e->set_look_shares(shares);
    }
    effectors.push_back(held);
  }

  // Joints: knees and elbows as hinges with human ranges, bending the way the rest pose says;
  // spine, chest and neck with cones.
  gdx::Array joints;
  // Knees flex to 165° (clinically 160°; the CMU boxer's recorded knees reach 164°, which a 150°
  // limit left out of reach), elbows to 150° (the recordings reach 143°). The elbows get no
  // posture (stiffness 0): their bend follows from the hand's distance to the shoulder, so a pull
  // toward the incoming bend can only be served by moving the shoulder, i.e. the torso; a T-pose's
  // straight elbow, on its bound, leaned the replayed CMU boxer's torso ~30° to straighten the
  // arms, which then followed each punch with the torso (docs/benchmarks.md, IKBody).
  auto add_hinge = [&](const char* bone, const char* child, bool bends_forward, double max_deg, double stiffness) {
    const glm::dmat4 rest = global_rest(skel, bone_of(bone));
    const glm::dvec3 axis_in_skeleton = glm::normalize(glm::dvec3(rest[0]));  // the bone's +X
    const glm::dvec3 child_in_bone = gdx::to_glm(skel.get_bone_rest(bone_of(child)).origin);
    const glm::dvec3 along = glm::dmat3(rest) * child_in_bone;
    // +X turns the child toward axis x along; the character faces +Z: knees bend it back, elbows forward.
    const double forward = glm::cross(axis_in_skeleton, along).z;
    const double sign = (forward > 0.0) == bends_forward ? 1.0 : -1.0;
    gdx::ObjectPtr object = nullptr;
    const gdx::Variant held = new_resource("IKChainJoint", object);
    IKChainJoint* j = gdx::instance_of<IKChainJoint>(object, gdx::String("IKChainJoint"));
    if (j == nullptr) return;
    j->set_bone_name(gdx::String(bone));
    j->set_type(IKChainJoint::JOINT_HINGE);
    j->set_hinge_axis(gdx::from_glm(glm::dvec3(sign, 0.0, 0.0)));
    j->set_hinge_limit_enabled(true);
    j->set_hinge_min(0.0);
    j->set_hinge_max(max_deg * kDeg);
    j->set_posture_stiffness(stiffness);
    joints.push_back(held);
  };
  auto add_cone = [&](const char* bone, double cone_deg, double twist_deg, double motion_cost) {
    gdx::ObjectPtr object = nullptr;
    const gdx::Variant held = new_resource("IKChainJoint", object);
    IKChainJoint* j = gdx::instance_of<IKChainJoint>(object, gdx::String("IKChainJoint"));
    if (j == nullptr) return;
    j->set_bone_name(gdx::String(bone));
    j->set_cone_limit_enabled(true);
    j->set_cone_angle(cone_deg * kDeg);
    j->set_twist_limit_enabled(true);
    j->set_twist_min(-twist_deg * kDeg);
    j->set_twist_max(twist_deg * kDeg);
    j->set_motion_cost(motion_cost);
    joints.push_back(held);
  };
  add_hinge("LeftLowerLeg", "LeftFoot", false, 165.0, 0.1);
  add_hinge("RightLowerLeg", "RightFoot", false, 165.0, 0.1);
  add_hinge("LeftLowerArm", "LeftHand", true, 150.0, 0.0);
  add_hinge("RightLowerArm", "RightHand", true, 150.0, 0.0);
  // The spine bends reluctantly (motion cost 2): arms reach first, the spine joins when they cannot.
  add_cone("Spine", 30.0, 30.0, 2.0);
  if (bone_of("Chest") >= 0) add_cone("Chest", 30.0, 30.0, 2.0);
  if (bone_of("UpperChest") >= 0) add_cone("UpperChest", 30.0, 30.0, 2.0);
  if (bone_of("Neck") >= 0) add_cone("Neck", 40.0, 60.0, 1.0);

  set_root_bone(gdx::String("Hips"));
  set_floating_root(true);
  set_joints(joints);
  set_effectors(effectors);
  gdx::Object(owner_).notify_property_list_changed();
  return true;
}

}  // namespace ikchain::godot
