// A small BVH (Biovision hierarchy) reader for the body benchmark: plain structs, no engine.
//
// The format: HIERARCHY lists joints depth-first (ROOT, then nested JOINT blocks), each with an
// OFFSET from its parent (file units) and CHANNELS (any of Xposition Yposition Zposition Xrotation
// Yrotation Zrotation, in the order the frame lines store them); "End Site" blocks are leaves with
// only an OFFSET. MOTION gives "Frames: N", "Frame Time: s" and N lines of numbers, the channels of
// every joint in hierarchy order. Rotations are in degrees; a joint's local rotation is the product
// of its rotation channels in file order, R = R_c1 * R_c2 * R_c3 (acting on column vectors: the
// last channel is applied first), e.g. "Zrotation Xrotation Yrotation" gives Rz * Rx * Ry.
//
// World (the file's) frames, with p = parent (identity / 0 for the root):
//   o_j = o_p + Q_p * (offset_j + position channels of j)      Q_j = Q_p * R_j
// so the joint order is a parents array with parent[j] < j (what ikchain::TreeBuilder wants).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace bvh {

enum class Channel : uint8_t { kXposition, kYposition, kZposition, kXrotation, kYrotation, kZrotation };
const char* to_string(Channel c);

struct Joint {
  std::string name;
  int parent = -1;                  // earlier joint index, -1 for the root
  glm::dvec3 offset{0.0};           // from the parent's frame, file units
  std::vector<Channel> channels;    // in file order
  int first_channel = 0;            // index of channels[0] in a frame's values
  bool has_end_site = false;
  glm::dvec3 end_site{0.0};         // the End Site's offset in this joint's frame (file units)
};

struct Clip {
  std::vector<Joint> joints;        // depth-first, parents first
  int channel_count = 0;            // values per frame
  int frame_count = 0;
  double frame_time = 0.0;          // s
  std::vector<double> values;       // frame_count x channel_count, frame-major
  int ignored_values = 0;           // numbers after the declared frames (an exporter's extra line)

  const double* frame(int f) const { return values.data() + static_cast<size_t>(f) * channel_count; }
  int find(const std::string& name) const;  // joint index by name, -1 if none
  std::vector<int> children(int joint) const;
};

// Parses BVH text. On failure returns false and `error` says where (line number) and why.
bool parse(const std::string& text, Clip& out, std::string& error);
bool load(const std::string& path, Clip& out, std::string& error);

// Joint j's local rotation in `frame` (its rotation channels composed in file order; identity
// when it has none) and translation (OFFSET plus its position channels), file units.
glm::dquat local_rotation(const Clip& clip, int joint, const double* frame);
glm::dvec3 local_translation(const Clip& clip, int joint, const double* frame);

// World origins and orientations of every joint in `frame` (file units).
void forward_kinematics(const Clip& clip, const double* frame, std::vector<glm::dvec3>& origins,
                        std::vector<glm::dquat>& orientations);

}  // namespace bvh
