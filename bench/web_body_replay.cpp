// The web page's body frames replayed natively: the calls demo/tests/bench/body_frames.mjs --record
// made on the wasm module's WebTree (one per line: its JS name, then its numbers; a solve line ends
// with "# <wasm iterations>"), made again on src/wasm/web_tree.cpp compiled natively (it has no
// embind), so the same solves can be timed in both builds.
//
//   build/bench_obj/web_body_replay CALLS [--skip N] [--repeat N] [--idle MS]
//
// --skip: solves not counted at the start (the node script's untimed first second; default 60).
// --idle MS: before each solve, a 32 MB pass over memory and MS ms asleep (the node script's --idle).
// Prints the core's µs per solve (elapsed_us), the wall time around solve() and the iterations, and
// on how many solves the iterations equal the wasm's.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "wasm/web_tree.hpp"

namespace {

using ikchain::web::WebTree;

struct Call {
  std::string name;
  std::vector<double> args;
  int wasm_iterations = -1;
};

double quantile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size())))];
}

double mean(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x;
  return s / static_cast<double>(v.size());
}

// Makes one recorded call; false for a name it does not know.
bool make_call(WebTree& t, const Call& c) {
  const std::vector<double>& a = c.args;
  const std::string& n = c.name;
  if (n == "addBall") t.add_ball(a[0], a[1], a[2], a[3], a[4] != 0, a[5], a[6], a[7], a[8], a[9], a[10], a[11]);
  else if (n == "addHinge") t.add_hinge(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7] != 0, a[8], a[9], a[10]);
  else if (n == "addEffector") t.add_effector(a[0], a[1], a[2], a[3]);
  else if (n == "setFloatingRoot") t.set_floating_root(a[0] != 0, a[1]);
  else if (n == "build") return t.build().empty();
  else if (n == "clearGoals") t.clear_goals();
  else if (n == "addPositionGoal") t.add_position_goal(a[0], a[1], a[2], a[3], a[4], a[5]);
  else if (n == "addOrientationGoal") t.add_orientation_goal(a[0], a[1], a[2], a[3], a[4], a[5], a[6]);
  else if (n == "addAimGoal") t.add_aim_goal(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8]);
  else if (n == "setPosture") t.set_posture(a.data(), static_cast<int>(a.size()) - 1, a.back());
  else if (n == "setPostureIterations") t.set_posture_iterations(static_cast<int>(a[0]));
  else if (n == "setParams") t.set_params(a.data(), static_cast<int>(a.size()));
  else if (n == "setMaxIterations") t.set_max_iterations(static_cast<int>(a[0]));
  else if (n == "setTolerances") t.set_tolerances(a[0], a[1]);
  else if (n == "setWarmStart") t.set_warm_start(a[0] != 0);
  else if (n == "setTimeBudgetUsec") t.set_time_budget_usec(a[0]);
  else if (n == "setTimeCapUsec") t.set_time_cap_usec(a[0]);
  else if (n == "setGoalPosition") t.set_goal_position(static_cast<int>(a[0]), a[1], a[2], a[3]);
  else if (n == "setGoalOrientation") t.set_goal_orientation(static_cast<int>(a[0]), a[1], a[2], a[3], a[4]);
  else if (n == "setGoalAimDirection") t.set_goal_aim_direction(static_cast<int>(a[0]), a[1], a[2], a[3]);
  else return false;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s CALLS [--skip N] [--repeat N] [--idle MS]\n", argv[0]);
    return 2;
  }
  int skip = 60, repeat = 1, idle_ms = 0;
  for (int i = 2; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--skip")) skip = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--repeat")) repeat = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--idle")) idle_ms = std::atoi(argv[i + 1]);
  }
  std::ifstream in(argv[1]);
  if (!in) {
    std::fprintf(stderr, "cannot read %s\n", argv[1]);
    return 1;
  }
  std::vector<Call> calls;
  for (std::string line; std::getline(in, line);) {
    std::istringstream s(line);
    Call c;
    s >> c.name;
    for (std::string tok; s >> tok;) {
      if (tok == "#") {
        s >> c.wasm_iterations;
        break;
      }
      c.args.push_back(std::stod(tok));
    }
    if (!c.name.empty()) calls.push_back(c);
  }

  std::vector<double> junk(idle_ms > 0 ? (32u << 17) : 0);  // 32 MB
  volatile double sink = 0.0;
  std::vector<double> core_us, wall_us, iterations;
  int same = 0;
  for (int r = 0; r < repeat; ++r) {
    WebTree t;
    int solves = 0;
    for (const Call& c : calls) {
      if (c.name != "solve") {
        if (!make_call(t, c)) {
          std::fprintf(stderr, "call %s failed or is unknown\n", c.name.c_str());
          return 1;
        }
        continue;
      }
      if (idle_ms > 0) {
        for (size_t i = 0; i < junk.size(); i += 8) sink = sink + (junk[i] += 1.0);
        std::this_thread::sleep_for(std::chrono::milliseconds(idle_ms));
      }
      const auto t0 = std::chrono::steady_clock::now();
      t.solve(static_cast<int>(c.args[0]));
      const auto t1 = std::chrono::steady_clock::now();
      if (solves++ < skip) continue;
      const ikchain::SolveResult& s = t.last_result().summary;
      core_us.push_back(s.elapsed_us);
      wall_us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
      iterations.push_back(s.iterations);
      same += s.iterations == c.wasm_iterations;
    }
  }
  if (core_us.empty()) {
    std::fprintf(stderr, "no solves counted\n");
    return 1;
  }
  std::printf("native replay: %zu solves%s\n", core_us.size(), idle_ms > 0 ? ", idle + 32 MB pass before each" : "");
  std::printf("  core us per solve: median %.1f, mean %.1f, p90 %.1f, p99 %.1f\n", quantile(core_us, 0.5),
              mean(core_us), quantile(core_us, 0.9), quantile(core_us, 0.99));
  std::printf("  wall us around the call: median %.1f, mean %.1f\n", quantile(wall_us, 0.5), mean(wall_us));
  std::printf("  iterations: mean %.2f, the wasm's on %d of %zu solves\n", mean(iterations), same, core_us.size());
  return 0;
}
