// Body benchmark: effector replay on real motion capture (issue 14).
//
// Clips: the CMU recordings in Debian's assimp-testmodels (/usr/share/assimp/models/BVH/: 01_01
// hops, 01_03 ladder climb, Boxing_Toes). Each BVH skeleton becomes a body (body_model.hpp):
// every joint a ball, the root floating, human joint ranges. Per frame the recording's hips, both
// hands, both feet (each position + rotation) and the head (the top of the head + its rotation)
// are the goals; a solver must pose everything else. The recording's own params are the reference:
// MPJPE is the mean distance of every joint's origin from the recording's.
//
// Rows: clip x solver x start. Solvers: `chain_stack_dls` (the hips placed at the recording, then
// one ikchain::solve() per chain: spine -> head, each arm from the collar, each leg; see
// chain_stack.cpp) and, once the core has it, every tree solver (solve_tree, body_tree.cpp) with the
// rig of body_model.hpp (the trunk's motion cost, a neutral posture), and DLS again without the
// posture (`dls_no_posture`).
// Starts: "cold" = every frame from the rest pose (every joint at rest, the root at the recorded
// hips: both the stack and the tree start there) and "warm" = from the previous frame's result
// (the first frame from the rest pose), as a game does.
//
// Success per frame: every effector within 1 mm and 1 degree of its target, measured by this
// program's own forward kinematics (body_model.cpp), not by the solver's report. Times: this
// thread's CPU time (ikchain::Deadline::thread_cpu_now_us: CLOCK_THREAD_CPUTIME_ID) around the
// solver's call for the whole body (for the stack: all five chain solves and the forward kinematics
// that places each chain's base); the wall clock (steady_clock) is recorded beside it.
//
// Usage: body_bench [--out DIR] [--quick] [--frames N] [--clips DIR] [--solver ID] [--start cold|warm]
//   writes DIR/body.json (default build/bench) and prints one line per row; --solver and --start
//   keep only the rows of that solver id (e.g. dls, chain_stack_dls) or start, for profiling.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "bench_common.hpp"
#include "body_model.hpp"
#include "body_solvers.hpp"
#include "bvh.hpp"
#include "ikchain/deadline.hpp"
#include "ikchain/options.hpp"

namespace {

using bench::json_number;
using bench::json_string;
using bench::quantile;

// The clips and their length unit. CMU's BVH conversions keep the ASF/AMC lengths, which the CMU
// database FAQ converts to metres with (1/0.45) * 2.54 / 100 = 0.056444 m per unit (0.45 is the
// ASF header's length scale, the data in inches); Boxing_Toes is in centimetres.
struct ClipSpec {
  const char* name;
  const char* file;
  double metres_per_unit;
};
const ClipSpec kClips[] = {
    {"01_01", "01_01.bvh", (1.0 / 0.45) * 2.54 / 100.0},
    {"01_03", "01_03.bvh", (1.0 / 0.45) * 2.54 / 100.0},
    {"Boxing_Toes", "Boxing_Toes.bvh", 0.01},
};
constexpr double kSuccessPositionM = 1e-3;     // 1 mm
constexpr double kSuccessAngleDeg = 1.0;       // 1 degree
constexpr double kLimitSlackRad = 1e-6;        // a joint this far past a range counts as a violation
constexpr double kContactStepM = 1e-3;         // foot sliding: recorded foot moves < 1 mm per frame
constexpr int kQuickFrames = 60;

double angle_deg(const glm::dquat& a, const glm::dquat& b) {
  const double d = std::min(1.0, std::abs(glm::dot(a, b)));
  return glm::degrees(2.0 * std::acos(d));
}

double mean(const std::vector<double>& v) {
  if (v.empty()) return NAN;
  double s = 0;
  for (double x : v) s += x;
  return s / v.size();
}

// One clip, ready to replay: the recorded params, poses and targets of the frames used.
struct Replay {
  const ClipSpec* spec = nullptr;
  bvh::Clip clip;
  body::Model model;
  std::vector<int> frames;                    // clip frame indices
  std::vector<std::vector<double>> params;    // recorded
  std::vector<body::Pose> poses;              // recorded
  std::vector<body::Targets> targets;
  double stature_m = 0.0;
  double hips_height_m = 0.0;  // median over frames: the hips above the lowest joint
};

// Height of the rest pose (joints and End Sites), m.
double rest_stature(const body::Model& m, const bvh::Clip& clip) {
  std::vector<double> zero(m.dof_count(), 0.0);
  body::Pose pose;
  body::forward_kinematics(m, zero.data(), pose);
  double lo = 1e300, hi = -1e300;
  for (int j = 0; j < m.joint_count; ++j) {
    lo = std::min(lo, pose.origins[j].y);
    hi = std::max(hi, pose.origins[j].y);
    if (clip.joints[j].has_end_site) {
      const double y = (pose.origins[j] + pose.orientations[j] * (clip.joints[j].end_site * m.metres_per_unit)).y;
      lo = std::min(lo, y);
      hi = std::max(hi, y);
    }
  }
  return hi - lo;
}

struct Row {
  std::string clip, solver, start, note;
  int frames = 0, refused = 0, successes = 0, limit_frames = 0, limit_joints = 0;
  std::vector<double> cpu_us, wall_us, iterations, pos_mm, rot_deg, mpjpe_mm, slide_mm;
  double worst_effector_mm[body::kEffectorCount] = {};
  double worst_effector_deg[body::kEffectorCount] = {};
};

Row run(const Replay& r, body::BodySolver& solver, bool warm) {
  Row row;
  row.clip = r.spec->name;
  row.solver = solver.id();
  row.start = warm ? "warm" : "cold";
  const body::Model& m = r.model;
  std::vector<double> params(m.dof_count(), 0.0), prev_params;
  body::Pose pose, prev_pose;
  const int feet[2] = {body::kLeftFoot, body::kRightFoot};
  for (size_t f = 0; f < r.frames.size(); ++f) {
    if (!warm || f == 0) {
      // The rest pose with the root at the recorded hips.
      std::fill(params.begin(), params.end(), 0.0);
      for (int k = 0; k < 6; ++k) params[k] = r.params[f][k];
    }
    int iterations = 0;
    std::string note;
    const double c0 = ikchain::Deadline::thread_cpu_now_us();
    const auto w0 = std::chrono::steady_clock::now();
    const bool ok = solver.solve(r.targets[f], params.data(), iterations, note);
    const auto w1 = std::chrono::steady_clock::now();
    const double c1 = ikchain::Deadline::thread_cpu_now_us();
    if (!ok) {
      ++row.refused;
      if (row.note.empty()) row.note = note;
      continue;
    }
    ++row.frames;
    row.cpu_us.push_back(c1 - c0);
    row.wall_us.push_back(std::chrono::duration<double, std::micro>(w1 - w0).count());
    row.iterations.push_back(iterations);
    body::forward_kinematics(m, params.data(), pose);
    bool success = true;
    for (int e = 0; e < body::kEffectorCount; ++e) {
      const double dp = glm::length(body::effector_position(m, pose, e) - r.targets[f].position[e]);
      const double da = angle_deg(body::effector_orientation(m, pose, e), r.targets[f].orientation[e]);
      row.pos_mm.push_back(1e3 * dp);
      row.rot_deg.push_back(da);
      row.worst_effector_mm[e] = std::max(row.worst_effector_mm[e], 1e3 * dp);
      row.worst_effector_deg[e] = std::max(row.worst_effector_deg[e], da);
      if (!(dp <= kSuccessPositionM && da <= kSuccessAngleDeg)) success = false;
    }
    row.successes += success;
    double sum = 0.0;
    for (int j = 0; j < m.joint_count; ++j) sum += glm::length(pose.origins[j] - r.poses[f].origins[j]);
    row.mpjpe_mm.push_back(1e3 * sum / m.joint_count);
    const int violations = body::count_limit_violations(m, params.data(), kLimitSlackRad);
    row.limit_joints += violations;
    row.limit_frames += violations > 0;
    // Foot sliding: where the recorded foot stands (moves < 1 mm horizontally since the previous
    // frame), how far the solved foot's horizontal step differs from the recorded one.
    if (f > 0 && !prev_params.empty()) {
      for (int e : feet) {
        glm::dvec3 rec = body::effector_position(m, r.poses[f], e) - body::effector_position(m, r.poses[f - 1], e);
        glm::dvec3 got = body::effector_position(m, pose, e) - body::effector_position(m, prev_pose, e);
        rec.y = got.y = 0.0;
        if (glm::length(rec) < kContactStepM) row.slide_mm.push_back(1e3 * glm::length(got - rec));
      }
    }
    prev_params = params;
    prev_pose = pose;
  }
  return row;
}

std::string row_json(const Row& w) {
  const double n = std::max(1, w.frames);
  std::string s = "{";
  s += "\"clip\": " + json_string(w.clip);
  s += ", \"solver\": " + json_string(w.solver);
  s += ", \"start\": " + json_string(w.start);
  s += ", \"frames\": " + std::to_string(w.frames);
  s += ", \"refused_frames\": " + std::to_string(w.refused);
  s += ", \"success_rate\": " + json_number(w.frames ? w.successes / n : NAN);
  s += ", \"median_us\": " + json_number(quantile(w.cpu_us, 0.5));
  s += ", \"p99_us\": " + json_number(quantile(w.cpu_us, 0.99));
  s += ", \"mean_us\": " + json_number(mean(w.cpu_us));
  s += ", \"max_us\": " + json_number(quantile(w.cpu_us, 1.0));
  s += ", \"wall_median_us\": " + json_number(quantile(w.wall_us, 0.5));
  s += ", \"wall_p99_us\": " + json_number(quantile(w.wall_us, 0.99));
  s += ", \"mpjpe_mm\": " + json_number(mean(w.mpjpe_mm));
  s += ", \"limit_violations\": " + std::to_string(w.limit_frames);
  s += ", \"limit_violation_joints\": " + std::to_string(w.limit_joints);
  s += ", \"position_error_p50_mm\": " + json_number(quantile(w.pos_mm, 0.5));
  s += ", \"position_error_p99_mm\": " + json_number(quantile(w.pos_mm, 0.99));
  s += ", \"position_error_max_mm\": " + json_number(quantile(w.pos_mm, 1.0));
  s += ", \"rotation_error_p50_deg\": " + json_number(quantile(w.rot_deg, 0.5));
  s += ", \"rotation_error_p99_deg\": " + json_number(quantile(w.rot_deg, 0.99));
  s += ", \"rotation_error_max_deg\": " + json_number(quantile(w.rot_deg, 1.0));
  s += ", \"foot_slide_mm\": " + json_number(mean(w.slide_mm));
  s += ", \"foot_slide_p99_mm\": " + json_number(quantile(w.slide_mm, 0.99));
  s += ", \"foot_contact_steps\": " + std::to_string(w.slide_mm.size());
  s += ", \"median_iterations\": " + json_number(quantile(w.iterations, 0.5));
  s += ", \"mean_iterations\": " + json_number(mean(w.iterations));
  s += ", \"worst_effector_mm\": {";
  for (int e = 0; e < body::kEffectorCount; ++e)
    s += std::string(e ? ", " : "") + json_string(body::to_string(static_cast<body::Effector>(e))) + ": " +
         json_number(w.worst_effector_mm[e]);
  s += "}, \"worst_effector_deg\": {";
  for (int e = 0; e < body::kEffectorCount; ++e)
    s += std::string(e ? ", " : "") + json_string(body::to_string(static_cast<body::Effector>(e))) + ": " +
         json_number(w.worst_effector_deg[e]);
  s += "}";
  if (!w.note.empty()) s += ", \"note\": " + json_string(w.note);
  return s + "}";
}

// The recorded motion against the joint ranges: per class the largest swing and twist, and how
// many frames have some joint outside its range.
std::string ranges_json(const Replay& r, int& frames_outside) {
  const body::Model& m = r.model;
  double max_swing[body::kJointClassCount] = {}, min_twist[body::kJointClassCount] = {},
         max_twist[body::kJointClassCount] = {};
  bool seen[body::kJointClassCount] = {};
  frames_outside = 0;
  int joint_frames_outside = 0;
  for (const auto& p : r.params) {
    const int v = body::count_limit_violations(m, p.data(), kLimitSlackRad);
    frames_outside += v > 0;
    joint_frames_outside += v;
    for (int j = 1; j < m.joint_count; ++j) {
      double swing, twist;
      body::swing_twist_deg(m, j, p.data(), swing, twist);
      const int c = static_cast<int>(m.joint_class[j]);
      seen[c] = true;
      max_swing[c] = std::max(max_swing[c], swing);
      min_twist[c] = std::min(min_twist[c], twist);
      max_twist[c] = std::max(max_twist[c], twist);
    }
  }
  std::string s = "{\"frames_outside_ranges\": " + std::to_string(frames_outside) +
                  ", \"joint_frames_outside_ranges\": " + std::to_string(joint_frames_outside) + ", \"classes\": [";
  bool first = true;
  for (int c = 0; c < body::kJointClassCount; ++c) {
    if (!seen[c]) continue;
    const body::Range range = body::range_of(static_cast<body::JointClass>(c));
    std::string joints;
    for (int j = 1; j < m.joint_count; ++j)
      if (static_cast<int>(m.joint_class[j]) == c) joints += (joints.empty() ? "" : " ") + m.joint_names[j];
    char buf[512];
    std::snprintf(buf, sizeof(buf),
                  "%s{\"class\": \"%s\", \"joints\": %s, \"cone_deg\": %g, \"twist_min_deg\": %g, "
                  "\"twist_max_deg\": %g, \"recorded_max_swing_deg\": %.1f, \"recorded_min_twist_deg\": %.1f, "
                  "\"recorded_max_twist_deg\": %.1f}",
                  first ? "" : ", ", body::to_string(static_cast<body::JointClass>(c)), json_string(joints).c_str(),
                  range.cone_deg, range.twist_min_deg, range.twist_max_deg, max_swing[c], min_twist[c], max_twist[c]);
    s += buf;
    first = false;
  }
  return s + "]}";
}

}  // namespace

int main(int argc, char** argv) {
  std::string out_dir = "build/bench";
  std::string clips_dir = "/usr/share/assimp/models/BVH";
  bool quick = false;
  int max_frames = 0;  // 0 = every frame
  std::string only_solver;  // empty = every solver
  std::string only_start;   // empty = both
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--out") && i + 1 < argc) out_dir = argv[++i];
    else if (!std::strcmp(argv[i], "--clips") && i + 1 < argc) clips_dir = argv[++i];
    else if (!std::strcmp(argv[i], "--frames") && i + 1 < argc) max_frames = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--solver") && i + 1 < argc) only_solver = argv[++i];
    else if (!std::strcmp(argv[i], "--start") && i + 1 < argc) only_start = argv[++i];
    else if (!std::strcmp(argv[i], "--quick")) quick = true;
    else {
      std::fprintf(stderr, "usage: body_bench [--out DIR] [--quick] [--frames N] [--clips DIR] [--solver ID] [--start cold|warm]\n");
      return 2;
    }
  }
  if (quick && max_frames == 0) max_frames = kQuickFrames;
  (void)bench::start_loadavg();

  // The options every row uses (the stack's chains and the tree solvers alike): the core's
  // defaults (100 iterations, 1e-5 m, 1e-4 rad), no restarts, no time budget.
  const ikchain::SolverOptions options;

  std::string clips_json, records_json;
  std::printf("%-12s %-18s %-5s %6s %8s %9s %9s %9s %9s %9s %6s %6s\n", "clip", "solver", "start", "frames",
              "success", "median_us", "p99_us", "mpjpe_mm", "pos_p99mm", "rot_p99deg", "limit", "iter");
  for (const ClipSpec& spec : kClips) {
    Replay r;
    r.spec = &spec;
    std::string error;
    if (!bvh::load(clips_dir + "/" + spec.file, r.clip, error) ||
        !body::make_model(r.clip, spec.name, spec.metres_per_unit, r.model, error)) {
      std::fprintf(stderr, "body_bench: %s (scripts/setup installs Debian's assimp-testmodels)\n", error.c_str());
      return 1;
    }
    // Frame 0 of these files is the converter's reference pose, not motion: the replay starts at 1.
    const int last = max_frames > 0 ? std::min(r.clip.frame_count, 1 + max_frames) : r.clip.frame_count;
    for (int f = 1; f < last; ++f) r.frames.push_back(f);
    r.params.resize(r.frames.size());
    r.poses.resize(r.frames.size());
    r.targets.resize(r.frames.size());
    for (size_t k = 0; k < r.frames.size(); ++k) {
      r.params[k].assign(r.model.dof_count(), 0.0);
      body::recorded_params(r.clip, r.model, r.frames[k], r.params[k].data());
      body::forward_kinematics(r.model, r.params[k].data(), r.poses[k]);
      r.targets[k] = body::targets_at(r.model, r.poses[k]);
    }
    r.stature_m = rest_stature(r.model, r.clip);
    std::vector<double> hips_heights;
    for (const body::Pose& p : r.poses) {
      double lowest = 1e300;
      for (const glm::dvec3& o : p.origins) lowest = std::min(lowest, o.y);
      hips_heights.push_back(p.origins[0].y - lowest);
    }
    r.hips_height_m = quantile(hips_heights, 0.5);
    int frames_outside = 0;
    const std::string ranges = ranges_json(r, frames_outside);
    std::fprintf(stderr, "[body] %s: %d joints, %d params, %zu frames at %.4f s, %g m per unit, rest stature %.3f m, "
                 "hips %.3f m above the lowest joint, recorded frames outside the joint ranges: %d\n",
                 spec.name, r.model.joint_count, r.model.dof_count(), r.frames.size(), r.clip.frame_time,
                 spec.metres_per_unit, r.stature_m, r.hips_height_m, frames_outside);
    std::string chains;
    for (const body::ChainSpec& c : r.model.chains) {
      std::string joints;
      for (int j : c.joints) joints += (joints.empty() ? "" : " ") + r.model.joint_names[j];
      chains += std::string(chains.empty() ? "" : ", ") + "{\"chain\": " + json_string(c.name) +
                ", \"joints\": " + json_string(joints) + "}";
    }
    clips_json += std::string(clips_json.empty() ? "" : ",\n  ") + "{\"clip\": " + json_string(spec.name) +
                  ", \"file\": " + json_string(spec.file) + ", \"joints\": " + std::to_string(r.model.joint_count) +
                  ", \"params\": " + std::to_string(r.model.dof_count()) +
                  ", \"frames\": " + std::to_string(r.frames.size()) +
                  ", \"frame_time_s\": " + json_number(r.clip.frame_time) +
                  ", \"metres_per_unit\": " + json_number(spec.metres_per_unit) +
                  ", \"rest_stature_m\": " + json_number(r.stature_m) +
                  ", \"hips_height_m\": " + json_number(r.hips_height_m) + ", \"chains\": [" + chains +
                  "], \"recorded_ranges\": " + ranges + "}";

    std::vector<std::unique_ptr<body::BodySolver>> solvers;
    solvers.push_back(body::make_chain_stack(r.model, ikchain::SolverKind::kDLS, options));
    std::string tree_note;
    for (auto& s : body::make_tree_solvers(r.model, options, tree_note)) solvers.push_back(std::move(s));
    if (!tree_note.empty()) std::fprintf(stderr, "[body] %s: tree solvers: %s\n", spec.name, tree_note.c_str());
    for (auto& solver : solvers) {
      if (!only_solver.empty() && solver->id() != only_solver) continue;
      for (bool warm : {false, true}) {
        if (!only_start.empty() && only_start != (warm ? "warm" : "cold")) continue;
        const Row w = run(r, *solver, warm);
        std::printf("%-12s %-18s %-5s %6d %7.2f%% %9.1f %9.1f %9.2f %9.3f %9.3f %6d %6.1f%s%s\n", w.clip.c_str(),
                    w.solver.c_str(), w.start.c_str(), w.frames,
                    w.frames ? 100.0 * w.successes / w.frames : 0.0, quantile(w.cpu_us, 0.5),
                    quantile(w.cpu_us, 0.99), mean(w.mpjpe_mm), quantile(w.pos_mm, 0.99), quantile(w.rot_deg, 0.99),
                    w.limit_frames, quantile(w.iterations, 0.5), w.note.empty() ? "" : "  ", w.note.c_str());
        std::fflush(stdout);
        records_json += std::string(records_json.empty() ? "" : ",\n  ") + row_json(w);
      }
    }
  }

  std::string meta = bench::meta_json_head(quick);
  meta += ", \"frames_per_clip\": " + std::string(max_frames > 0 ? std::to_string(max_frames) : "\"all\"");
  meta += ", \"tree_solvers\": " + std::string(body::tree_solvers_available() ? "true" : "false");
  meta += ", \"success\": \"every effector (hips, hands, feet, head top) within 1 mm and 1 deg of the recording\"";
  meta += ", \"times\": \"median_us/p99_us/mean_us: this thread's CPU time (CLOCK_THREAD_CPUTIME_ID) per frame "
          "around the solver's call for the whole body; wall_*: steady_clock\"";
  meta += ", \"starts\": \"cold: every frame from the rest pose with the root at the recorded hips; warm: from the "
          "previous frame's result\"";
  meta += ", \"options\": \"SolverOptions defaults: max_iterations 100, position_tolerance 1e-5 m, "
          "orientation_tolerance 1e-4 rad, no restarts\"";
  meta += ", \"tree_rig\": \"every tree solver: motion cost " + bench::json_number(body::kTrunkMotionCost) +
          " on the spine, neck and collars; a posture task (dls_no_posture: none), the rest pose with the upper arms "
          "hanging " + bench::json_number(body::kNeutralArmDeg) + " deg out from straight down, stiffness 1 on trunk and "
          "head, 0.1 on the arms, 0 elsewhere, posture_iterations 1 (bench/body_model.hpp)\"";
  meta += "}";
  const std::string json = "{\"meta\": " + meta + ",\n \"clips\": [\n  " + clips_json + "],\n \"records\": [\n  " +
                           records_json + "]}\n";
  const std::string path = out_dir + "/body.json";
  if (!bench::write_file(path, json)) return 1;
  std::fprintf(stderr, "[body] wrote %s\n", path.c_str());
  return 0;
}
