// What the core bench and the robots bench share: quantiles, JSON text, the run's machine record
// (date, CPU, load) and KDL's return codes in our result vocabulary. Header-only, bench-local.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <string>
#include <vector>

#include <kdl/chainiksolverpos_lma.hpp>
#include <kdl/solveri.hpp>

namespace bench {

// Linear-interpolated quantile q in [0, 1] (NaN for no samples).
inline double quantile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const double pos = q * (v.size() - 1);
  const size_t lo = static_cast<size_t>(pos);
  const size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - lo) * (v[hi] - v[lo]);
}

// A JSON number, or null for NaN / inf (JSON has neither).
inline std::string json_number(double v, const char* fmt = "%.6g") {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, v);
  return buf;
}

inline std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    out += c;
  }
  return out + "\"";
}

inline bool write_file(const std::string& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
  if (!f) {
    std::fprintf(stderr, "cannot write %s\n", path.c_str());
    return false;
  }
  return true;
}

// The first line of a text file starting with `prefix` (its value after ": "), or its first line
// when prefix is null; "unknown" when there is none.
inline std::string read_first_line(const char* path, const char* prefix) {
  std::ifstream f(path);
  for (std::string line; std::getline(f, line);)
    if (!prefix || line.rfind(prefix, 0) == 0) return prefix ? line.substr(line.find(':') + 2) : line;
  return "unknown";
}

inline std::string loadavg() { return read_first_line("/proc/loadavg", nullptr); }

// The machine's load when the run started (other jobs on a shared machine inflate the times).
inline const std::string& start_loadavg() {
  static const std::string load = loadavg();
  return load;
}

// The opening fields of a bench JSON's "meta" record (without the closing brace): date (UTC), CPU,
// load at start and at write, compiler, flags, quick.
inline std::string meta_json_head(bool quick) {
  char date[32];
  const std::time_t now = std::time(nullptr);
  std::strftime(date, sizeof(date), "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  std::string s = "{";
  s += "\"date\": " + json_string(date);
  s += ", \"cpu\": " + json_string(read_first_line("/proc/cpuinfo", "model name"));
  s += ", \"loadavg_at_start\": " + json_string(start_loadavg());
  s += ", \"loadavg_at_write\": " + json_string(loadavg());
  s += ", \"compiler\": " + json_string(__VERSION__);
  s += ", \"flags\": \"-O2 -DNDEBUG\"";
  s += ", \"quick\": " + std::string(quick ? "true" : "false");
  return s;
}

// KDL's return codes in our result vocabulary (strError() gives whole sentences).
inline const char* kdl_reason(int rc) {
  switch (rc) {
    case KDL::SolverI::E_NOERROR: return "converged";
    case KDL::SolverI::E_MAX_ITERATIONS_EXCEEDED: return "max_iterations";
    case KDL::ChainIkSolverPos_LMA::E_GRADIENT_JOINTS_TOO_SMALL: return "gradient_too_small";
    case KDL::ChainIkSolverPos_LMA::E_INCREMENT_JOINTS_TOO_SMALL: return "increment_too_small";
    default: return "kdl_error";
  }
}

}  // namespace bench
