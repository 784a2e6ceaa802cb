#include "bvh.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

namespace bvh {

const char* to_string(Channel c) {
  switch (c) {
    case Channel::kXposition: return "Xposition";
    case Channel::kYposition: return "Yposition";
    case Channel::kZposition: return "Zposition";
    case Channel::kXrotation: return "Xrotation";
    case Channel::kYrotation: return "Yrotation";
    case Channel::kZrotation: return "Zrotation";
  }
  return "?";
}

int Clip::find(const std::string& name) const {
  for (size_t i = 0; i < joints.size(); ++i)
    if (joints[i].name == name) return static_cast<int>(i);
  return -1;
}

std::vector<int> Clip::children(int joint) const {
  std::vector<int> out;
  for (size_t i = 0; i < joints.size(); ++i)
    if (joints[i].parent == joint) out.push_back(static_cast<int>(i));
  return out;
}

namespace {

// Whitespace-separated tokens with their line numbers, read on demand.
class Tokens {
 public:
  explicit Tokens(const std::string& text) : p_(text.c_str()), end_(text.c_str() + text.size()) {}
  // The next token, or "" at the end.
  std::string next() {
    skip_space();
    const char* start = p_;
    while (p_ < end_ && !is_space(*p_)) ++p_;
    return std::string(start, p_);
  }
  bool number(double& v) {
    skip_space();
    if (p_ >= end_) return false;
    char* after = nullptr;
    errno = 0;
    v = std::strtod(p_, &after);
    if (after == p_ || (after < end_ && !is_space(*after)) || !std::isfinite(v)) return false;
    p_ = after;
    return true;
  }
  int line() const { return line_; }

 private:
  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }
  void skip_space() {
    while (p_ < end_ && is_space(*p_)) {
      if (*p_ == '\n') ++line_;
      ++p_;
    }
  }
  const char* p_;
  const char* end_;
  int line_ = 1;
};

bool fail(std::string& error, const Tokens& t, const std::string& what) {
  error = "line " + std::to_string(t.line()) + ": " + what;
  return false;
}

bool read_offset(Tokens& t, glm::dvec3& offset, std::string& error) {
  if (t.next() != "OFFSET") return fail(error, t, "expected OFFSET");
  for (int k = 0; k < 3; ++k)
    if (!t.number(offset[k])) return fail(error, t, "OFFSET needs 3 numbers");
  return true;
}

bool parse_channel(const std::string& s, Channel& c) {
  static const char* names[] = {"Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation"};
  for (int k = 0; k < 6; ++k)
    if (s == names[k]) {
      c = static_cast<Channel>(k);
      return true;
    }
  return false;
}

// After "ROOT name" / "JOINT name": { OFFSET CHANNELS (JOINT ... | End Site {...})* }
bool parse_joint(Tokens& t, Clip& clip, int parent, const std::string& name, std::string& error) {
  const int index = static_cast<int>(clip.joints.size());
  clip.joints.push_back({});
  clip.joints[index].name = name;
  clip.joints[index].parent = parent;
  if (t.next() != "{") return fail(error, t, "expected { after joint " + name);
  glm::dvec3 offset;
  if (!read_offset(t, offset, error)) return false;
  clip.joints[index].offset = offset;
  if (t.next() != "CHANNELS") return fail(error, t, "expected CHANNELS in joint " + name);
  double count = 0;
  if (!t.number(count) || count < 0 || count > 6 || count != std::floor(count))
    return fail(error, t, "CHANNELS needs a count in 0..6");
  clip.joints[index].first_channel = clip.channel_count;
  for (int k = 0; k < static_cast<int>(count); ++k) {
    const std::string s = t.next();
    Channel c;
    if (!parse_channel(s, c)) return fail(error, t, "unknown channel '" + s + "' in joint " + name);
    clip.joints[index].channels.push_back(c);
  }
  clip.channel_count += static_cast<int>(count);
  for (;;) {
    const std::string s = t.next();
    if (s == "}") return true;
    if (s == "JOINT") {
      const std::string child = t.next();
      if (child.empty()) return fail(error, t, "JOINT without a name");
      if (!parse_joint(t, clip, index, child, error)) return false;
    } else if (s == "End") {
      if (t.next() != "Site") return fail(error, t, "expected 'End Site'");
      if (t.next() != "{") return fail(error, t, "expected { after End Site");
      if (!read_offset(t, clip.joints[index].end_site, error)) return false;
      clip.joints[index].has_end_site = true;
      if (t.next() != "}") return fail(error, t, "expected } closing End Site");
    } else {
      return fail(error, t, "unexpected '" + s + "' in joint " + name);
    }
  }
}

glm::dquat axis_rotation(Channel c, double degrees) {
  const double a = glm::radians(degrees);
  const glm::dvec3 axis = c == Channel::kXrotation ? glm::dvec3(1, 0, 0)
                          : c == Channel::kYrotation ? glm::dvec3(0, 1, 0)
                                                     : glm::dvec3(0, 0, 1);
  return glm::angleAxis(a, axis);
}

}  // namespace

bool parse(const std::string& text, Clip& out, std::string& error) {
  out = Clip{};
  Tokens t(text);
  if (t.next() != "HIERARCHY") return fail(error, t, "expected HIERARCHY");
  if (t.next() != "ROOT") return fail(error, t, "expected ROOT");
  const std::string root = t.next();
  if (root.empty()) return fail(error, t, "ROOT without a name");
  if (!parse_joint(t, out, -1, root, error)) return false;
  for (const Joint& j : out.joints)
    for (size_t k = 0; k < j.channels.size(); ++k)
      if (j.channels[k] <= Channel::kZposition && j.parent != -1)
        return fail(error, t, "joint " + j.name + ": position channels only on the root");
  if (t.next() != "MOTION") return fail(error, t, "expected MOTION (a single ROOT)");
  if (t.next() != "Frames:") return fail(error, t, "expected Frames:");
  double frames = 0;
  if (!t.number(frames) || frames < 0 || frames != std::floor(frames)) return fail(error, t, "bad frame count");
  if (t.next() != "Frame" || t.next() != "Time:") return fail(error, t, "expected Frame Time:");
  if (!t.number(out.frame_time) || !(out.frame_time > 0)) return fail(error, t, "bad frame time");
  out.frame_count = static_cast<int>(frames);
  out.values.resize(static_cast<size_t>(out.frame_count) * out.channel_count);
  for (size_t k = 0; k < out.values.size(); ++k)
    if (!t.number(out.values[k]))
      return fail(error, t, "frame " + std::to_string(k / out.channel_count) + ": expected " +
                                std::to_string(out.channel_count) + " numbers");
  // Some exporters write one more frame line than "Frames:" says (Boxing_Toes.bvh: 3,070 lines
  // for 3,069 frames): the declared count rules, what follows is counted and ignored.
  double extra = 0.0;
  while (t.number(extra)) ++out.ignored_values;
  if (!t.next().empty()) return fail(error, t, "unexpected text after the frames");
  return true;
}

bool load(const std::string& path, Clip& out, std::string& error) {
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    error = "cannot open " + path;
    return false;
  }
  std::stringstream ss;
  ss << f.rdbuf();
  if (!parse(ss.str(), out, error)) {
    error = path + ": " + error;
    return false;
  }
  return true;
}

glm::dquat local_rotation(const Clip& clip, int joint, const double* frame) {
  const Joint& j = clip.joints[joint];
  glm::dquat q(1.0, 0.0, 0.0, 0.0);
  for (size_t k = 0; k < j.channels.size(); ++k)
    if (j.channels[k] >= Channel::kXrotation) q = q * axis_rotation(j.channels[k], frame[j.first_channel + k]);
  return q;
}

glm::dvec3 local_translation(const Clip& clip, int joint, const double* frame) {
  const Joint& j = clip.joints[joint];
  glm::dvec3 t = j.offset;
  for (size_t k = 0; k < j.channels.size(); ++k)
    if (j.channels[k] <= Channel::kZposition) t[static_cast<int>(j.channels[k])] += frame[j.first_channel + k];
  return t;
}

void forward_kinematics(const Clip& clip, const double* frame, std::vector<glm::dvec3>& origins,
                        std::vector<glm::dquat>& orientations) {
  const size_t n = clip.joints.size();
  origins.resize(n);
  orientations.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const int p = clip.joints[i].parent;
    const glm::dvec3 t = local_translation(clip, static_cast<int>(i), frame);
    const glm::dquat r = local_rotation(clip, static_cast<int>(i), frame);
    if (p < 0) {
      origins[i] = t;
      orientations[i] = r;
    } else {
      origins[i] = origins[p] + orientations[p] * t;
      orientations[i] = orientations[p] * r;
    }
  }
}

}  // namespace bvh
