// IKModifier: what the IKChain and IKBody nodes share as SkeletonModifier3Ds, so a second (third)
// node does not copy it: the skeleton they sit under and its signals, the bone-name drop-down,
// the dirty flag with change notification per resource (each IKChainJoint, IKChainGoal,
// IKBodyEffector in the node's arrays tells its owner, not every node of the scene), the solve
// settings common to both (solver, max_iterations, tolerance, orientation_tolerance,
// deterministic) and their binding.
#pragma once

#include <gdextension_interface.h>

#include <cstdint>
#include <string>

#include "binding/builtins.hpp"
#include "binding/class_db.hpp"
#include "ikchain/ikchain.hpp"
#include "solver_choice.hpp"

namespace ikchain::godot {

class IKModifier {
 public:
  // What differs between the nodes in the shared settings.
  struct Traits {
    const char* class_name;           // "IKChain": messages and the SOLVER_* constants' enum
    int64_t default_max_iterations;
    const char* tolerance_range;      // the clamp message's range, with its unit
    bool solver_change_rebuilds;      // IKBody: a solver that takes no trees stops the body
    bool deterministic_is_cold_start; // IKChain: deterministic starts from the rest pose
    const char* no_skeleton_frame;    // the result of a frame without a skeleton parent
    const char* no_skeleton_fix;      // the result of solve_now() without one: with the fix
  };
  static constexpr double kDefaultTolerance = 1e-4;             // skeleton units
  static constexpr double kDefaultOrientationTolerance = 1e-3;  // rad

  // Class-wide StringNames: created at SCENE init, destroyed at SCENE deinit.
  static void register_names();
  static void unregister_names();

  virtual ~IKModifier() = default;

  // ---- shared properties
  void set_root_bone(const gdx::String& name);
  gdx::String get_root_bone() const;
  void set_solver(int64_t solver);
  int64_t get_solver() const { return solver_; }
  void set_max_iterations(int64_t n);
  int64_t get_max_iterations() const { return max_iterations_; }
  void set_tolerance(double units);
  double get_tolerance() const { return tolerance_; }
  void set_orientation_tolerance(double radians);
  double get_orientation_tolerance() const { return orientation_tolerance_; }
  void set_deterministic(bool on);
  bool is_deterministic() const { return deterministic_; }
  void set_time_budget_usec(double usec);
  double get_time_budget_usec() const { return time_budget_usec_; }

  // ---- engine callbacks
  void process_modification(double delta);
  void notification(int32_t what);
  void skeleton_changed();  // virtual _skeleton_changed and the skeleton's bone signals
  void resource_changed();  // `changed` of a resource in the node's arrays (bound as _resource_changed)

  // Binds the shared methods, the Solver constants and the shared solver properties (call inside
  // the node's "Solver" group; `deterministic` is bound by bind_deterministic(), so each node keeps
  // its inspector order).
  template <class C>
  static void bind_solver_settings(gdx::ClassBuilder<C>& b, const char* solver_enum, bool trees_only);
  template <class C>
  static void bind_deterministic(gdx::ClassBuilder<C>& b);
  // time_budget_usec (SolverOptions::time_budget_usec: a frame's solve stops once it is spent).
  template <class C>
  static void bind_time_budget(gdx::ClassBuilder<C>& b);
  // root_bone, with its bone-name drop-down (validate_property()).
  template <class C>
  static void bind_root_bone(gdx::ClassBuilder<C>& b);

 protected:
  IKModifier(gdx::ObjectPtr owner, const Traits& traits);

  // The parent skeleton (also before the node has entered the tree: the editor asks for warnings
  // at any time).
  gdx::Skeleton3D skeleton() const;
  // Connects the skeleton's bone signals to skeleton_changed().
  void watch_skeleton(const gdx::Skeleton3D& skeleton);
  // The bone-name drop-down of a bone property (free text without a skeleton).
  void bone_drop_down(GDExtensionPropertyInfo& property) const;
  bool is_bone_property(GDExtensionConstStringNamePtr name) const;
  // Connects `changed` of every resource in `resources` to this node (once each).
  void listen_to(const gdx::Array& resources);
  // Disconnects them (an array the node no longer holds).
  void stop_listening_to(const gdx::Array& resources);
  void set_listening(const gdx::Array& resources, bool on);
  void mark_dirty();        // rebuild before the next solve; the warnings may change
  void settings_changed();  // no rebuild, but the warnings may change
  // A resource of the node changed: IKChain rebuilds, IKBody rebuilds only when the change reshapes
  // the body (its effectors' targets and weights are read every frame).
  virtual void on_resource_changed() { mark_dirty(); }
  // The node's solve of one frame (false: nothing written) and its result when nothing was done.
  virtual bool run(const gdx::Skeleton3D& skeleton) = 0;
  virtual void set_invalid_result(const char* message) = 0;
  // solve_now(): one frame's solve, now.
  void run_now();
  SolverKind choice_kind() const { return find_solver_choice(solver_)->kind; }
  bool solver_is_auto() const { return find_solver_choice(solver_)->is_auto; }

  gdx::ObjectPtr owner_;
  const Traits& traits_;
  bool dirty_ = true;

  std::string root_bone_;
  int64_t solver_ = kSolverAutoValue;
  int64_t max_iterations_;
  double tolerance_ = kDefaultTolerance;
  double orientation_tolerance_ = kDefaultOrientationTolerance;
  bool deterministic_ = false;
  double time_budget_usec_ = 0.0;
  SolverOptions options_;
};

template <class C>
void IKModifier::bind_solver_settings(gdx::ClassBuilder<C>& b, const char* solver_enum, bool trees_only) {
  namespace hint = gdx::gen::PropertyHint;
  b.method("set_solver", &IKModifier::set_solver, {"solver"});
  b.method("get_solver", &IKModifier::get_solver, {}, {solver_enum});
  b.method("set_max_iterations", &IKModifier::set_max_iterations, {"iterations"});
  b.method("get_max_iterations", &IKModifier::get_max_iterations);
  b.method("set_tolerance", &IKModifier::set_tolerance, {"tolerance"});
  b.method("get_tolerance", &IKModifier::get_tolerance);
  b.method("set_orientation_tolerance", &IKModifier::set_orientation_tolerance, {"radians"});
  b.method("get_orientation_tolerance", &IKModifier::get_orientation_tolerance);
  b.method("_resource_changed", &IKModifier::resource_changed);
  for (const SolverChoice& c : kSolverChoices) b.constant("Solver", c.constant, c.value);
  const std::string solver_hint_string = solver_hint(trees_only);
  b.property({"solver", GDEXTENSION_VARIANT_TYPE_INT, hint::PROPERTY_HINT_ENUM, solver_hint_string.c_str()},
             "set_solver", "get_solver");
  b.property({"max_iterations", GDEXTENSION_VARIANT_TYPE_INT, hint::PROPERTY_HINT_RANGE, "1,1000,1"},
             "set_max_iterations", "get_max_iterations");
  b.property({"tolerance", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE,
              "0.000001,1,0.000001,exp,suffix:m"},
             "set_tolerance", "get_tolerance");
  b.property({"orientation_tolerance", GDEXTENSION_VARIANT_TYPE_FLOAT, hint::PROPERTY_HINT_RANGE,
              "0.000001,1,0.000001,exp,suffix:rad"},
             "set_orientation_tolerance", "get_orientation_tolerance");
}

template <class C>
void IKModifier::bind_deterministic(gdx::ClassBuilder<C>& b) {
  b.method("set_deterministic", &IKModifier::set_deterministic, {"enabled"});
  b.method("is_deterministic", &IKModifier::is_deterministic);
  b.property({"deterministic", GDEXTENSION_VARIANT_TYPE_BOOL}, "set_deterministic", "is_deterministic");
}

template <class C>
void IKModifier::bind_time_budget(gdx::ClassBuilder<C>& b) {
  b.method("set_time_budget_usec", &IKModifier::set_time_budget_usec, {"usec"});
  b.method("get_time_budget_usec", &IKModifier::get_time_budget_usec);
  b.property({"time_budget_usec", GDEXTENSION_VARIANT_TYPE_FLOAT, gdx::gen::PropertyHint::PROPERTY_HINT_RANGE,
              "0,100000,1,or_greater,suffix:us"},
             "set_time_budget_usec", "get_time_budget_usec");
}

template <class C>
void IKModifier::bind_root_bone(gdx::ClassBuilder<C>& b) {
  b.method("set_root_bone", &IKModifier::set_root_bone, {"bone_name"});
  b.method("get_root_bone", &IKModifier::get_root_bone);
  b.property({"root_bone", GDEXTENSION_VARIANT_TYPE_STRING, gdx::gen::PropertyHint::PROPERTY_HINT_ENUM, ""},
             "set_root_bone", "get_root_bone");
}

}  // namespace ikchain::godot
